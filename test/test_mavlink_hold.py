"""The bridge's hold order (mavlink/mode_orders.py): a formation with every pose NaN after one
with targets sends every vehicle into its hold mode, through real MAVLink bytes on loopback UDP to
SITL-style vehicles (no ROS)."""
import math
import time

import pytest
from mavlink_fakes import MAV, wait_until

from uav_insar_planner.autopilots.profiles import profile
from uav_insar_planner.mavlink.bridge import Bridge, BridgeConfig
from uav_insar_planner.mavlink.mode_orders import ATTEMPTS, hold_order
from uav_insar_planner.mavlink.supervision import WatchedVehicle
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(60)
SYSIDS = (2, 3, 4)
FORMATION = [(-5.0, 0.0, 12.0), (0.0, 0.0, 15.0), (5.0, 0.0, 12.0)]
HOLD = [(math.nan, 0.0, math.nan)] * 3


@pytest.mark.parametrize("autopilot,flying,holding", [("ardupilot", "GUIDED", "LOITER"),
                                                      ("px4", "OFFBOARD", "HOLD")])
def test_all_nan_formation_puts_every_vehicle_in_its_hold_mode(autopilot, flying, holding):
    vehicles = [SimVehicle(s, "udpin:127.0.0.1:0", autopilot, start_ned=(2.0 * k, 0.0, -8.0),
                           max_speed=15.0, max_accel=10.0, airborne=True)
                for k, s in enumerate(SYSIDS)]
    for v in vehicles:
        v.start()
    bridge = Bridge(BridgeConfig(connections=tuple(f"udpout:127.0.0.1:{v.port}"
                                                   for v in vehicles),
                                 target_sysids=SYSIDS, autopilot=autopilot, speed_mps=2.0))
    try:
        with bridge:
            bridge.set_formation(HOLD)  # all NaN before any target: nothing to stop
            bridge.set_formation(FORMATION)
            assert wait_until(bridge.track_started, 10.0)
            assert all(v.mode == flying for v in vehicles)
            bridge.set_formation(HOLD)
            assert wait_until(lambda: all(v.mode == holding for v in vehicles), 5.0), \
                [v.mode for v in vehicles]
            where = [v.position_ned for v in vehicles]
            time.sleep(1.0)
            events = [e.text for e in bridge.drain_events()]
        # they hold where they were (braking from 2 m/s), and were told once each
        for v, before in zip(vehicles, where, strict=True):
            assert math.dist(v.position_ned, before) < 1.5
            modes = [c for c in v.commands if c[0] == MAV.MAV_CMD_DO_SET_MODE]
            assert modes[-1] == (MAV.MAV_CMD_DO_SET_MODE, MAV.MAV_RESULT_ACCEPTED)
            assert len(modes) <= 2
        name = "LOITER" if autopilot == "ardupilot" else "AUTO.LOITER"
        assert f"every pose NaN: the mission stopped; commanding {name} to every vehicle" \
            in events
        assert sum("DO_SET_MODE: ACCEPTED" in e for e in events) >= 3
    finally:
        for v in vehicles:
            v.stop()


def test_hold_order_is_resent_a_few_times_then_given_up():
    order = hold_order(profile("ardupilot"))
    v = WatchedVehicle(0, 2, link=None, linked=True, custom_mode=4)
    assert not order.due(v, 0.0)  # not engaged
    order.engage([v.uav])
    sent = 0
    for t in range(20):
        if order.due(v, t * 0.5):
            order.sent(v, t * 0.5)
            sent += 1
    assert sent == ATTEMPTS
    v.custom_mode, v.last_heartbeat = 5, 99.0
    order.engage([v.uav])
    # in LOITER as last heard, but heard before the order: a hold order still on its way
    # may be what put it there, or not; sent once more
    assert order.due(v, 100.0)
    order.sent(v, 100.0)
    v.last_heartbeat = 100.5  # a heartbeat after the order shows LOITER: done
    assert not order.due(v, 101.5)
    order.engage([v.uav])
    v.custom_mode, v.linked = 4, False
    assert not order.due(v, 102.0)  # not linked: when it comes back
    order.release()
    v.linked = True
    assert not order.due(v, 100.0)
    custom = float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
    assert hold_order(profile("px4")).params == (custom, 4.0, 3.0)
