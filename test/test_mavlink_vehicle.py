"""The SITL-style vehicle against a bare pymavlink ground station on loopback UDP."""
import time

import pytest
from mavlink_fakes import MAV, FakePeer, wait_until

from uav_insar_planner.mavlink.autopilots import px4_custom_mode
from uav_insar_sim.vehicle import SimVehicle, main

pytestmark = pytest.mark.timeout(60)
ACCEPTED = MAV.MAV_RESULT_ACCEPTED


@pytest.fixture
def rig(request):
    autopilot, airborne = request.param
    vehicle = SimVehicle(5, "udpin:127.0.0.1:0", autopilot, start_ned=(0.0, 0.0, -10.0 if
                         airborne else 0.0), max_speed=15.0, max_accel=10.0,
                         airborne=airborne)
    vehicle.start()
    gcs = FakePeer(255, 191, dest=("127.0.0.1", vehicle.port), heartbeat_hz=2.0,
                   mav_type=MAV.MAV_TYPE_GCS, autopilot=MAV.MAV_AUTOPILOT_INVALID)
    yield vehicle, gcs
    gcs.close()
    vehicle.stop()


def command(gcs, cmd, *params, timeout=2.0):
    since = time.monotonic()
    p = list(params) + [0.0] * (7 - len(params))
    gcs.mav.send(gcs.mav.command_long_encode(5, 1, cmd, 0, *p))
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for _, m in gcs.messages("COMMAND_ACK", since):
            if m.command == cmd:
                assert (m.target_system, m.target_component) == (255, 191)
                return m.result
        time.sleep(0.01)
    raise AssertionError(f"no COMMAND_ACK for {cmd}")


def setpoint(gcs, n, e, d, frame=MAV.MAV_FRAME_LOCAL_NED, mask=3576, v=(0.0, 0.0, 0.0)):
    gcs.mav.send(gcs.mav.set_position_target_local_ned_encode(
        0, 5, 1, frame, mask, n, e, d, *v, 0, 0, 0, 0, 0))


@pytest.mark.parametrize("rig", [("ardupilot", False)], indirect=True)
def test_ardupilot_heartbeat_position_rate_and_guided_takeoff(rig):
    vehicle, gcs = rig
    hb = gcs.wait_for("HEARTBEAT", 3.0)
    assert hb.autopilot == MAV.MAV_AUTOPILOT_ARDUPILOTMEGA and hb.type == MAV.MAV_TYPE_QUADROTOR
    assert hb.custom_mode == 0 and hb.get_srcSystem() == 5
    t0 = time.monotonic()
    time.sleep(2.05)
    n = len(gcs.messages("LOCAL_POSITION_NED", t0))
    assert n == pytest.approx(20, rel=0.2)
    setpoint(gcs, 0, 0, -5)
    time.sleep(0.2)
    assert vehicle.setpoints_rejected == 1  # not in GUIDED yet
    assert command(gcs, MAV.MAV_CMD_NAV_TAKEOFF, *[0] * 6, 5.0) == MAV.MAV_RESULT_FAILED
    assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 4) == ACCEPTED
    assert command(gcs, MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1) == ACCEPTED
    assert command(gcs, MAV.MAV_CMD_NAV_TAKEOFF, *[0] * 6, 5.0) == ACCEPTED
    assert wait_until(lambda: abs(vehicle.position_ned[2] + 5.0) < 0.2, 6.0)
    hb = gcs.wait_for("HEARTBEAT", 2.0, time.monotonic())
    assert hb.custom_mode == 4 and hb.base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED
    assert command(gcs, MAV.MAV_CMD_COMPONENT_ARM_DISARM, 0) == MAV.MAV_RESULT_FAILED  # flying
    assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 77) == MAV.MAV_RESULT_FAILED
    assert command(gcs, MAV.MAV_CMD_DO_FLIGHTTERMINATION, 1) == MAV.MAV_RESULT_UNSUPPORTED


@pytest.mark.parametrize("rig", [("ardupilot", True)], indirect=True)
def test_ardupilot_frames_and_masks(rig):
    vehicle, gcs = rig
    gcs.wait_for("HEARTBEAT", 3.0)
    setpoint(gcs, 100, 100, -50, frame=MAV.MAV_FRAME_GLOBAL_RELATIVE_ALT)  # wrong message
    setpoint(gcs, 100, 100, -50, mask=3576 | 0b001)  # x ignored but not y, z
    time.sleep(0.3)
    assert vehicle.setpoints_rejected == 2 and vehicle.setpoints_accepted == 0
    setpoint(gcs, 3, 4, -12)
    assert wait_until(lambda: sum((a - b) ** 2 for a, b in
                                  zip(vehicle.position_ned, (3, 4, -12), strict=True)) < 0.09,
                      6.0)
    setpoint(gcs, 1, 0, 0, frame=MAV.MAV_FRAME_LOCAL_OFFSET_NED)  # 1 m north of here
    assert wait_until(lambda: abs(vehicle.position_ned[0] - 4.0) < 0.3, 4.0)
    # the classic trap: mask 0 uses every field, so x = y = z = 0 flies to the origin
    setpoint(gcs, 0, 0, 0, mask=0)
    assert wait_until(lambda: abs(vehicle.position_ned[2]) < 0.5
                      and abs(vehicle.position_ned[0]) < 0.5, 8.0)


@pytest.mark.parametrize("rig", [("px4", False)], indirect=True)
def test_px4_offboard_needs_a_stream_and_falls_back_to_hold(rig):
    vehicle, gcs = rig
    hb = gcs.wait_for("HEARTBEAT", 3.0)
    assert hb.autopilot == MAV.MAV_AUTOPILOT_PX4 and hb.custom_mode == px4_custom_mode("POSCTL")
    assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 6, 0) == MAV.MAV_RESULT_TEMPORARILY_REJECTED
    setpoint(gcs, 0, 0, -5, frame=MAV.MAV_FRAME_LOCAL_OFFSET_NED)  # PX4 refuses this frame
    assert wait_until(lambda: vehicle.setpoints_rejected == 1, 1.0)
    t0 = time.monotonic()
    while time.monotonic() - t0 < 1.3:
        setpoint(gcs, 0, 0, -5)
        time.sleep(0.1)
    assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 6, 0) == ACCEPTED
    assert command(gcs, MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1) == ACCEPTED
    while time.monotonic() - t0 < 3.5:  # the offboard setpoint is the takeoff
        setpoint(gcs, 0, 0, -5)
        time.sleep(0.1)
    assert vehicle.mode == "OFFBOARD" and abs(vehicle.position_ned[2] + 5.0) < 0.3
    time.sleep(0.8)  # the stream stops: PX4 leaves offboard after its timeout
    assert vehicle.mode == "HOLD"
    here = vehicle.position_ned
    time.sleep(0.5)
    assert max(abs(a - b) for a, b in zip(here, vehicle.position_ned, strict=True)) < 0.3
    hb = gcs.wait_for("HEARTBEAT", 2.0, time.monotonic())
    assert hb.custom_mode == px4_custom_mode("HOLD")


@pytest.mark.parametrize("rig", [("px4", False)], indirect=True)
def test_px4_set_mode_message_and_takeoff_mode(rig):
    vehicle, gcs = rig
    gcs.wait_for("HEARTBEAT", 3.0)
    assert command(gcs, MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1) == ACCEPTED
    assert command(gcs, MAV.MAV_CMD_NAV_TAKEOFF, *[0] * 6, float("nan")) == ACCEPTED
    assert vehicle.mode == "TAKEOFF"
    assert wait_until(lambda: vehicle.mode == "HOLD", 5.0)
    assert abs(vehicle.position_ned[2] + 2.5) < 0.3
    since = time.monotonic()
    gcs.mav.send(gcs.mav.set_mode_encode(5, MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                         px4_custom_mode("LAND")))
    assert wait_until(lambda: any(m.command == MAV.MAVLINK_MSG_ID_SET_MODE
                                  for _, m in gcs.messages("COMMAND_ACK", since)), 2.0)
    assert wait_until(lambda: not vehicle.armed and vehicle.landed, 6.0)


def test_messages_for_other_systems_are_ignored():
    with SimVehicle(5, "udpin:127.0.0.1:0", "ardupilot", airborne=True,
                    start_ned=(0, 0, -10)) as vehicle:
        gcs = FakePeer(255, 191, dest=("127.0.0.1", vehicle.port))
        try:
            gcs.mav.send(gcs.mav.set_position_target_local_ned_encode(
                0, 6, 1, MAV.MAV_FRAME_LOCAL_NED, 3576, 9, 9, -9, 0, 0, 0, 0, 0, 0, 0, 0))
            gcs.mav.send(gcs.mav.command_long_encode(6, 1, 400, 0, 0, 0, 0, 0, 0, 0, 0))
            time.sleep(0.3)
            assert vehicle.setpoints_accepted == 0 and vehicle.commands == []
        finally:
            gcs.close()


def test_cli_rejects_bad_arguments(capsys):
    assert main(["--sysid", "0", "--listen", "udpin:127.0.0.1:0"]) == 2
    assert "sysid" in capsys.readouterr().err
    assert main(["--sysid", "2", "--listen", "bogus"]) == 2
