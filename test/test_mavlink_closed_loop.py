"""Bridge + three SITL-style vehicles, all through real MAVLink bytes on loopback UDP."""
import math
import time

import pytest
from mavlink_fakes import MAV, wait_until

from uav_insar_planner.mavlink.bridge import Bridge, BridgeConfig
from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_planner.track.passes import run_in_m
from uav_insar_planner.track.speed_profile import ramp_up
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(60)
SYSIDS = (2, 3, 4)
FORMATION = [(-5.0, 0.0, 12.0), (0.0, 0.0, 15.0), (5.0, 0.0, 12.0)]


def fly(autopilot, airborne, **bridge_kw):
    vehicles = [SimVehicle(s, "udpin:127.0.0.1:0", autopilot,
                           start_ned=(2.0 * k, -3.0 * k, -8.0 if airborne else 0.0),
                           max_speed=15.0, max_accel=10.0, airborne=airborne)
                for k, s in enumerate(SYSIDS)]
    for v in vehicles:
        v.start()
    config = BridgeConfig(connections=tuple(f"udpout:127.0.0.1:{v.port}" for v in vehicles),
                          target_sysids=SYSIDS, autopilot=autopilot, **bridge_kw)
    return vehicles, Bridge(config)


def errors(bridge, vehicles, now):
    """Distance of each vehicle (its true position) from its current track target."""
    out = []
    for k, v in enumerate(vehicles):
        target, _ = bridge.target(k, now)
        out.append(math.dist(bridge.frame.to_ned(*target), v.position_ned))
    return out


@pytest.mark.parametrize("feedforward", [False, True])
def test_vehicles_reach_the_formation_and_fly_the_track(feedforward):
    vehicles, bridge = fly("ardupilot", True, track_bearing_deg=30.0,
                           origin_ned_m=(5.0, -5.0, 0.0), speed_mps=2.0,
                           velocity_feedforward=feedforward)
    try:
        with bridge:
            bridge.set_formation(FORMATION)
            assert wait_until(bridge.track_started, 10.0)
            # established: every vehicle within the 1 m capture radius of its entry
            time.sleep(3.0)
            errs = errors(bridge, vehicles, time.monotonic())
            statuses = bridge.status()
        if feedforward:
            assert max(errs) < 0.5, errs
        else:  # position-only: a lag of v / gain behind the moving target, same for all
            assert max(errs) < 2.0, errs
        for k, s in enumerate(statuses):
            assert s.link == "linked"
            # flew along the track: the target ramped up from the hover at its entry, a
            # run-in before the line (4.7 m in 3 s at 2 m/s), the vehicle at most 2 m behind
            # it (position-only)
            assert s.position_track[1] > ramp_up(3.0, 2.0)[0] - run_in_m(2.0) - 2.0
            assert s.position_track[1] < ramp_up(3.0, 2.0)[0] - run_in_m(2.0) + 0.5
            assert s.position_track[0] == pytest.approx(FORMATION[k][0], abs=0.5)
            assert s.position_track[2] == pytest.approx(FORMATION[k][2], abs=0.5)
    finally:
        for v in vehicles:
            v.stop()


def test_formation_held_when_the_track_has_ended():
    vehicles, bridge = fly("px4", True, speed_mps=3.0, track_duration_s=1.0)
    try:
        with bridge:
            bridge.set_formation(FORMATION)
            assert wait_until(bridge.track_started, 10.0)
            # until the target stopped (the run-in, 1 s of pass, the braking), and a second
            time.sleep(PassClock(0.0, 3.0, -run_in_m(3.0), 1.0).time_at(3.0) + 1.0)
            errs = errors(bridge, vehicles, time.monotonic())
        assert max(errs) < 0.5, errs
        for k, v in enumerate(vehicles):
            x, y, z = bridge.frame.from_ned(*v.position_ned)
            assert (x, y, z) == pytest.approx((FORMATION[k][0], 3.0, FORMATION[k][2]), abs=0.5)
            assert v.mode == "OFFBOARD"
    finally:
        for v in vehicles:
            v.stop()


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
def test_arm_and_takeoff_sequence_is_acknowledged(autopilot):
    vehicles, bridge = fly(autopilot, False, arm_and_takeoff=True, speed_mps=1.0,
                           velocity_feedforward=True)
    try:
        with bridge:
            bridge.set_formation(FORMATION)
            assert wait_until(lambda: all(s.sequence == "done" for s in bridge.status()), 15.0)
            assert wait_until(bridge.track_started, 15.0)
            time.sleep(1.0)
            errs = errors(bridge, vehicles, time.monotonic())
            events = [e.text for e in bridge.drain_events()]
        assert max(errs) < 0.5, errs
        expected = ([MAV.MAV_CMD_DO_SET_MODE, MAV.MAV_CMD_COMPONENT_ARM_DISARM,
                     MAV.MAV_CMD_NAV_TAKEOFF] if autopilot == "ardupilot" else
                    [MAV.MAV_CMD_DO_SET_MODE, MAV.MAV_CMD_COMPONENT_ARM_DISARM])
        for v in vehicles:
            sequence = [c for c in v.commands if c[0] != MAV.MAV_CMD_SET_MESSAGE_INTERVAL]
            assert sequence == [(c, MAV.MAV_RESULT_ACCEPTED) for c in expected]
            assert v.armed and v.mode == ("GUIDED" if autopilot == "ardupilot" else "OFFBOARD")
        wanted = ["mode GUIDED: ACCEPTED", "arm: ACCEPTED", "takeoff: ACCEPTED"] \
            if autopilot == "ardupilot" else ["mode OFFBOARD: ACCEPTED", "arm: ACCEPTED"]
        for sysid in SYSIDS:
            for w in wanted:
                assert f"sysid {sysid} {w}" in events
    finally:
        for v in vehicles:
            v.stop()


def test_a_refused_command_is_reported_and_does_not_stop_the_others():
    vehicles, bridge = fly("ardupilot", False, arm_and_takeoff=True)
    port = vehicles[1].port  # replace UAV 1 by a PX4-like one: GUIDED (4) is no PX4 mode
    vehicles[1].stop()
    vehicles[1] = SimVehicle(3, f"udpin:127.0.0.1:{port}", "px4")
    vehicles[1].start()
    try:
        with bridge:
            bridge.set_formation(FORMATION)
            assert wait_until(lambda: bridge.status()[1].sequence.startswith("failed"), 10.0)
            assert wait_until(lambda: bridge.status()[0].sequence == "done"
                              and bridge.status()[2].sequence == "done", 15.0)
            assert wait_until(bridge.track_started, 10.0)
            events = bridge.drain_events()
        assert any(e.level == "error" and e.uav == 1 and "UNSUPPORTED" in e.text
                   for e in events)
    finally:
        for v in vehicles:
            v.stop()
