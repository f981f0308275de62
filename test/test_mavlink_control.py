"""A vehicle that leaves the bridge's control (mavlink/control_states.py), through real
MAVLink bytes on loopback UDP to SITL-style vehicles (no ROS): a ground station or pilot,
played by this test with pymavlink on the vehicle's own port (the fault's only injection),
orders one vehicle into another mode or disarms it in the air while the bridge flies it. The
bridge says so within a second, naming the mode, and fights it not: no mode order, no arming
command and no setpoint to it afterwards. With ROS and the planner's re-plan:
test_leaving_control.py."""
import math
import time

import pytest
from mavlink_fakes import MAV, wait_until
from pymavlink import mavutil

from uav_insar_planner.autopilots.profiles import profile
from uav_insar_planner.mavlink.bridge import Bridge, BridgeConfig
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(60)
SYSIDS = (2, 3, 4)
FORMATION = [(-5.0, 0.0, 12.0), (0.0, 0.0, 15.0), (5.0, 0.0, 12.0)]
GCS_SYSID, GCS_COMPID = 255, MAV.MAV_COMP_ID_MISSIONPLANNER  # a pilot's ground station
FORCE = 21196  # COMPONENT_ARM_DISARM's force: disarm in the air


def pilot(port: int) -> mavutil.mavfile:
    """A second ground station on the vehicle's own UDP port (the vehicle obeys sysid 255)."""
    return mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=GCS_SYSID,
                                      source_component=GCS_COMPID, dialect="ardupilotmega")


def order_mode(gcs: mavutil.mavfile, sysid: int, params: tuple[float, ...]) -> None:
    gcs.mav.command_long_send(sysid, 1, MAV.MAV_CMD_DO_SET_MODE, 0,
                              float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED),
                              *params, *[0.0] * (6 - len(params)))


def disarm(gcs: mavutil.mavfile, sysid: int) -> None:
    gcs.mav.command_long_send(sysid, 1, MAV.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0.0, FORCE,
                              0.0, 0.0, 0.0, 0.0, 0.0)


# (autopilot, flight mode, the pilot's mode (the profile's hold or home; None: a disarm), what
# the bridge names)
CASES = [("ardupilot", "GUIDED", "hold", "LOITER"), ("ardupilot", "GUIDED", "home", "RTL"),
         ("px4", "OFFBOARD", "hold", "AUTO.LOITER"), ("px4", "OFFBOARD", "home", "AUTO.RTL"),
         ("ardupilot", "GUIDED", None, "disarmed in the air"),
         ("px4", "OFFBOARD", None, "disarmed in the air")]


@pytest.mark.parametrize("autopilot,flying,mode,shown", CASES)
def test_a_vehicle_taken_from_the_bridge_is_said_and_not_fought(autopilot, flying, mode,
                                                                 shown):
    vehicles = [SimVehicle(s, "udpin:127.0.0.1:0", autopilot, start_ned=(2.0 * k, 0.0, -8.0),
                           max_speed=15.0, max_accel=10.0, airborne=True)
                for k, s in enumerate(SYSIDS)]
    for v in vehicles:
        v.start()
    bridge = Bridge(BridgeConfig(connections=tuple(f"udpout:127.0.0.1:{v.port}"
                                                   for v in vehicles),
                                 target_sysids=SYSIDS, autopilot=autopilot, speed_mps=2.0,
                                 arm_and_takeoff=True))
    ap, taken = profile(autopilot), vehicles[1]
    gcs = pilot(taken.port)
    try:
        with bridge:
            bridge.set_formation(FORMATION)
            assert wait_until(bridge.track_started, 15.0)
            time.sleep(1.0)
            assert all(v.mode == flying and v.armed for v in vehicles)
            assert all(s.out_of_control == "" for s in bridge.status())
            if mode is None:
                disarm(gcs, taken.sysid)
                assert wait_until(lambda: not taken.armed, 3.0)
            else:
                order_mode(gcs, taken.sysid, getattr(ap, mode).set_params)
                assert wait_until(lambda: taken.mode != flying, 3.0), taken.mode
            changed = time.monotonic()
            commands_before = len(taken.commands)  # the pilot's own command answered
            assert wait_until(lambda: bridge.status()[1].out_of_control, 2.5)
            said = time.monotonic() - changed
            status = bridge.status()[1]
            sent = status.setpoints_sent
            time.sleep(3.0)  # what would a fighting bridge send meanwhile?
            events = [e for e in bridge.drain_events() if e.uav == 1]
            after = bridge.status()
        # said: within a heartbeat period and the bridge's reading of it (< 1 s + 1 Hz HB)
        assert said < 2.0, said
        assert status.phase == f"out of our control: {shown}"
        assert status.out_of_control == status.phase
        lines = [e.text for e in events if "out of our control" in e.text]
        assert len(lines) == 1 and lines[0].startswith(f"sysid 3 out of our control: {shown}")
        assert [e for e in events if e.level == "warn"] == [
            e for e in events if "out of our control" in e.text]
        # not fought: no command answered since (mode, arm), no setpoint sent
        assert len(taken.commands) <= commands_before + 1  # (+1: the pilot's ACK racing)
        assert not [c for c in list(taken.commands)[commands_before + 1:]]
        assert after[1].setpoints_sent == sent
        assert shown == "disarmed in the air" or taken.mode != flying
        # the others fly on
        assert [s.out_of_control for s in after] == ["", status.phase, ""]
        assert all(v.mode == flying and v.armed for v in (vehicles[0], vehicles[2]))
        assert all(math.isfinite(c) for c in vehicles[0].position_ned)
    finally:
        gcs.close()
        for v in vehicles:
            v.stop()
