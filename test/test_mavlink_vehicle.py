"""The SITL-style vehicle against a bare pymavlink ground station on loopback UDP."""
import time

import pytest
from mavlink_fakes import MAV, FakePeer, wait_until
from process_group import kill_group

from uav_insar_planner.autopilots.profiles import px4_custom_mode
from uav_insar_sim.vehicle.cli import main
from uav_insar_sim.vehicle.simulator import SimVehicle

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
            assert vehicle.setpoints_accepted == 0 and not vehicle.commands
        finally:
            gcs.close()


def test_cli_rejects_bad_arguments(capsys):
    assert main(["--sysid", "0", "--listen", "udpin:127.0.0.1:0"]) == 2
    assert "sysid" in capsys.readouterr().err
    assert main(["--sysid", "2", "--listen", "bogus"]) == 2


# ------------------------------------------------------------------ ground-station realism
def gcs_for(vehicle, sysid=255):
    return FakePeer(sysid, 191, dest=("127.0.0.1", vehicle.port), heartbeat_hz=2.0,
                    mav_type=MAV.MAV_TYPE_GCS, autopilot=MAV.MAV_AUTOPILOT_INVALID)


@pytest.mark.parametrize("autopilot, refused", [
    ("ardupilot", MAV.MAV_RESULT_FAILED), ("px4", MAV.MAV_RESULT_TEMPORARILY_REJECTED)])
def test_boot_phase_refuses_arming_with_a_reason_then_arms(autopilot, refused):
    with SimVehicle(5, "udpin:127.0.0.1:0", autopilot, boot_s=3.0) as vehicle:
        gcs = gcs_for(vehicle)
        try:
            gcs.wait_for("HEARTBEAT", 3.0)
            if autopilot == "ardupilot":  # accepted while booting, but it does not stick
                assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 4) == ACCEPTED
            t0 = time.monotonic()
            assert command(gcs, MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1) == refused
            text = gcs.wait_for("STATUSTEXT", 2.0, t0)
            assert text.text.startswith(("PreArm:", "Preflight Fail:"))
            assert not gcs.messages("LOCAL_POSITION_NED") and not gcs.messages("HOME_POSITION")
            assert command(gcs, MAV.MAV_CMD_REQUEST_MESSAGE,
                           MAV.MAVLINK_MSG_ID_SYS_STATUS) == ACCEPTED
            sys_status = gcs.wait_for("SYS_STATUS", 1.0, t0)
            assert not sys_status.onboard_control_sensors_health & MAV.MAV_SYS_STATUS_PREARM_CHECK
            assert gcs.wait_for("GPS_RAW_INT", 2.0, t0).fix_type < 3
            assert not vehicle.booted and wait_until(lambda: vehicle.booted, 4.0)
            assert vehicle.mode == ("POSCTL" if autopilot == "px4" else "STABILIZE")
            t1 = time.monotonic()
            assert gcs.wait_for("GPS_RAW_INT", 2.0, t1).fix_type == 3
            assert gcs.wait_for("SYS_STATUS", 2.0, t1).onboard_control_sensors_health \
                & MAV.MAV_SYS_STATUS_PREARM_CHECK
            gcs.wait_for("LOCAL_POSITION_NED", 2.0, t1)
            home = gcs.wait_for("HOME_POSITION", 3.0, t1)
            assert (home.latitude, home.longitude, home.altitude) == (-353632610, 1491652300,
                                                                     584000)
            assert command(gcs, MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1) == ACCEPTED
        finally:
            gcs.close()


@pytest.mark.parametrize("rig", [("px4", False)], indirect=True)
def test_nan_and_garbage_command_params_never_crash(rig):
    vehicle, gcs = rig
    gcs.wait_for("HEARTBEAT", 3.0)
    nan, inf = float("nan"), float("inf")
    for cmd, params in [
            (MAV.MAV_CMD_COMPONENT_ARM_DISARM, (nan,)), (MAV.MAV_CMD_COMPONENT_ARM_DISARM, (inf,)),
            (MAV.MAV_CMD_COMPONENT_ARM_DISARM, (1, inf)), (MAV.MAV_CMD_COMPONENT_ARM_DISARM, (-3,)),
            (MAV.MAV_CMD_DO_SET_MODE, (nan, 6)), (MAV.MAV_CMD_DO_SET_MODE, (1, 3e38)),
            (MAV.MAV_CMD_DO_SET_MODE, (1, 4, -inf)), (MAV.MAV_CMD_DO_SET_MODE, (1, 3.5)),
            (MAV.MAV_CMD_SET_MESSAGE_INTERVAL, (nan, 1e5)),
            (MAV.MAV_CMD_SET_MESSAGE_INTERVAL, (32, nan)),
            (MAV.MAV_CMD_SET_MESSAGE_INTERVAL, (32, -7)),
            (MAV.MAV_CMD_SET_MESSAGE_INTERVAL, (32, 3e38)),
            (MAV.MAV_CMD_REQUEST_MESSAGE, (inf,)),
            (MAV.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, 0, 0, 0, inf))]:
        assert command(gcs, cmd, *params) in (MAV.MAV_RESULT_DENIED, MAV.MAV_RESULT_FAILED), \
            (cmd, params)
    assert vehicle.errors == 0 and not vehicle.armed
    # NaN where a parameter is unused: PX4 tools fill every unused one with NaN
    assert command(gcs, MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1, nan, nan, nan, nan, nan,
                   nan) == ACCEPTED
    assert command(gcs, MAV.MAV_CMD_NAV_TAKEOFF, nan, nan, nan, nan, nan, nan, nan) == ACCEPTED
    gcs.mav.send(gcs.mav.command_int_encode(5, 1, 0, MAV.MAV_CMD_DO_SET_MODE, 0, 0, 1, 4,
                                            nan, nan, 0, 0, nan))
    assert wait_until(lambda: vehicle.mode == "HOLD", 5.0)
    setpoint(gcs, nan, 0, -5)
    setpoint(gcs, 0, inf, -5)
    time.sleep(0.3)
    assert vehicle.setpoints_rejected == 2
    assert all(c == c for c in vehicle.position_ned)  # never NaN
    t0 = time.monotonic()
    time.sleep(0.5)
    assert len(gcs.messages("LOCAL_POSITION_NED", t0)) >= 3  # position reports keep flowing


@pytest.mark.parametrize("rig", [("ardupilot", False)], indirect=True)
def test_request_message_and_message_interval(rig):
    vehicle, gcs = rig
    gcs.wait_for("HEARTBEAT", 3.0)
    t0 = time.monotonic()
    assert command(gcs, MAV.MAV_CMD_REQUEST_MESSAGE,
                   MAV.MAVLINK_MSG_ID_AUTOPILOT_VERSION) == ACCEPTED
    version = gcs.wait_for("AUTOPILOT_VERSION", 2.0, t0)
    for cap in (MAV.MAV_PROTOCOL_CAPABILITY_MAVLINK2, MAV.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT,
                MAV.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED,
                MAV.MAV_PROTOCOL_CAPABILITY_COMMAND_INT):
        assert version.capabilities & cap
    assert command(gcs, MAV.MAV_CMD_REQUEST_MESSAGE, 12345) == MAV.MAV_RESULT_FAILED
    for name in ("GLOBAL_POSITION_INT", "HOME_POSITION", "GPS_RAW_INT", "ATTITUDE",
                 "EXTENDED_SYS_STATE", "BATTERY_STATUS", "SYS_STATUS"):
        since = time.monotonic()
        assert command(gcs, MAV.MAV_CMD_REQUEST_MESSAGE,
                       getattr(MAV, f"MAVLINK_MSG_ID_{name}")) == ACCEPTED
        gcs.wait_for(name, 1.0, since)
    gpi = gcs.messages("GLOBAL_POSITION_INT")[-1][1]
    assert (gpi.lat, gpi.lon, gpi.alt, gpi.relative_alt) == (-353632610, 1491652300, 584000, 0)
    assert command(gcs, MAV.MAV_CMD_SET_MESSAGE_INTERVAL, MAV.MAVLINK_MSG_ID_ATTITUDE,
                   -1) == ACCEPTED
    assert command(gcs, MAV.MAV_CMD_SET_MESSAGE_INTERVAL, MAV.MAVLINK_MSG_ID_BATTERY_STATUS,
                   100000) == ACCEPTED
    time.sleep(0.2)
    t1 = time.monotonic()
    time.sleep(1.0)
    assert not gcs.messages("ATTITUDE", t1)
    assert len(gcs.messages("BATTERY_STATUS", t1)) == pytest.approx(10, abs=2)
    assert gcs.wait_for("EXTENDED_SYS_STATE", 2.0, t1).landed_state == \
        MAV.MAV_LANDED_STATE_ON_GROUND


def param(gcs, name, since, timeout=2.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for _, m in gcs.messages("PARAM_VALUE", since):
            if m.param_id == name:
                return m
        time.sleep(0.01)
    return None


@pytest.mark.parametrize("rig", [("ardupilot", True)], indirect=True)
def test_parameter_protocol(rig):
    vehicle, gcs = rig
    gcs.wait_for("HEARTBEAT", 3.0)
    t0 = time.monotonic()
    gcs.mav.send(gcs.mav.param_request_list_encode(5, 1))
    assert wait_until(lambda: len(gcs.messages("PARAM_VALUE", t0)) == len(vehicle.params), 2.0)
    values = {m.param_id: m for _, m in gcs.messages("PARAM_VALUE", t0)}
    assert values["SYSID_THISMAV"].param_value == 5 and values["MAV_GCS_SYSID"].param_value == 255
    assert values["WPNAV_SPEED"].param_value == pytest.approx(1500.0)
    assert sorted(m.param_index for m in values.values()) == list(range(len(vehicle.params)))
    t1 = time.monotonic()
    gcs.mav.send(gcs.mav.param_request_read_encode(5, 1, b"WPNAV_SPEED", -1))
    assert param(gcs, "WPNAV_SPEED", t1).param_count == len(vehicle.params)
    gcs.mav.send(gcs.mav.param_set_encode(5, 1, b"WPNAV_SPEED", 500.0,
                                          MAV.MAV_PARAM_TYPE_REAL32))
    assert param(gcs, "WPNAV_SPEED", t1 + 1e-6) is not None
    assert wait_until(lambda: vehicle._ap.max_speed == pytest.approx(5.0), 1.0)
    for bad in (float("nan"), float("inf"), -3.0, 3e38):  # refused: the value stays
        t2 = time.monotonic()
        gcs.mav.send(gcs.mav.param_set_encode(5, 1, b"WPNAV_SPEED", bad,
                                              MAV.MAV_PARAM_TYPE_REAL32))
        assert param(gcs, "WPNAV_SPEED", t2).param_value == pytest.approx(500.0)
    t3 = time.monotonic()
    gcs.mav.send(gcs.mav.param_set_encode(5, 1, b"SYSID_THISMAV", 9, MAV.MAV_PARAM_TYPE_INT32))
    assert param(gcs, "SYSID_THISMAV", t3).param_value == 5  # read-only here
    gcs.mav.send(gcs.mav.param_request_read_encode(5, 1, b"NO_SUCH_PARAM", -1))
    time.sleep(0.2)
    assert param(gcs, "NO_SUCH_PARAM", t3, timeout=0.1) is None and vehicle.errors == 0


def test_only_the_configured_ground_station_commands():
    with SimVehicle(5, "udpin:127.0.0.1:0", "ardupilot", airborne=True,
                    start_ned=(0, 0, -10), gcs_sysid=200) as vehicle:
        other, mine = gcs_for(vehicle, 255), gcs_for(vehicle, 200)
        try:
            other.wait_for("HEARTBEAT", 3.0)
            setpoint(other, 9, 9, -9)
            other.mav.send(other.mav.command_long_encode(5, 1, 400, 0, 0, *[0] * 6))
            t0 = time.monotonic()
            other.mav.send(other.mav.param_request_read_encode(5, 1, b"MAV_GCS_SYSID", -1))
            assert param(other, "MAV_GCS_SYSID", t0).param_value == 200  # reads are open
            other.mav.send(other.mav.param_set_encode(5, 1, b"MAV_GCS_SYSID", 0,
                                                      MAV.MAV_PARAM_TYPE_INT32))
            time.sleep(0.3)
            assert vehicle.setpoints_accepted == 0 and not vehicle.commands
            assert vehicle.gcs_sysid == 200
            setpoint(mine, 1, 2, -9)
            assert wait_until(lambda: vehicle.setpoints_accepted == 1, 1.0)
        finally:
            other.close()
            mine.close()


@pytest.mark.parametrize("rig", [("ardupilot", True)], indirect=True)
def test_ardupilot_guided_in_guided_keeps_the_target_and_brake_rtl(rig):
    vehicle, gcs = rig
    gcs.wait_for("HEARTBEAT", 3.0)
    setpoint(gcs, 6, 0, -10)
    assert wait_until(lambda: vehicle.position_ned[0] > 1.0, 3.0)
    assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 4) == ACCEPTED  # GUIDED again
    assert wait_until(lambda: abs(vehicle.position_ned[0] - 6.0) < 0.2, 6.0)
    setpoint(gcs, 20, 0, -10)
    assert wait_until(lambda: vehicle.velocity_ned[0] > 3.0, 4.0)
    assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 17) == ACCEPTED  # BRAKE
    assert wait_until(lambda: abs(vehicle.velocity_ned[0]) < 0.05, 4.0)
    stopped = vehicle.position_ned
    time.sleep(0.5)
    assert abs(vehicle.position_ned[0] - stopped[0]) < 0.1 and vehicle.position_ned[0] < 19.0
    for mode in (2, 5, 0):  # ALT_HOLD, LOITER, STABILIZE: hold (no RC modelled)
        assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, mode) == ACCEPTED
    assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 6) == ACCEPTED  # RTL: home, then land
    assert wait_until(lambda: vehicle.landed and not vehicle.armed, 20.0)
    assert max(abs(c) for c in vehicle.position_ned) < 0.3


@pytest.mark.parametrize("rig", [("px4", False)], indirect=True)
def test_px4_offboard_needs_only_a_recent_setpoint(rig):
    vehicle, gcs = rig
    gcs.wait_for("HEARTBEAT", 3.0)
    setpoint(gcs, 0, 0, -4)  # one setpoint, then OFFBOARD at once (MAVSDK's order)
    time.sleep(0.1)
    assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 6, 0) == ACCEPTED
    assert vehicle.mode == "OFFBOARD"
    setpoint(gcs, 0, 0, -4)
    assert command(gcs, MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1) == ACCEPTED
    time.sleep(0.8)  # no stream: PX4 leaves OFFBOARD
    assert vehicle.mode == "HOLD"
    assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 6, 0) == MAV.MAV_RESULT_TEMPORARILY_REJECTED
    for name, (main_mode, sub) in (("ALTCTL", (2, 0)), ("MANUAL", (1, 0)), ("RTL", (4, 5)),
                              ("HOLD", (4, 3))):
        assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, main_mode, sub) == ACCEPTED
        assert vehicle.mode == name
    assert command(gcs, MAV.MAV_CMD_DO_SET_MODE, 1, 4, 9) == MAV.MAV_RESULT_UNSUPPORTED


def test_cli_starts_a_booting_vehicle_with_a_home():
    import subprocess
    import sys
    probe = FakePeer(1)  # a free UDP port
    port = probe.port
    probe.close()
    proc = subprocess.Popen([sys.executable, "-m", "uav_insar_sim.vehicle", "--sysid", "5",
                             "--listen", f"udpin:127.0.0.1:{port}", "--boot-s", "0",
                             "--home", "47.0,8.0,400"], stdout=subprocess.PIPE, text=True,
                            start_new_session=True)
    gcs = FakePeer(255, 191, dest=("127.0.0.1", port), heartbeat_hz=2.0)
    try:
        gpi = gcs.wait_for("GLOBAL_POSITION_INT", 10.0)
        assert (gpi.lat, gpi.lon, gpi.alt) == (470000000, 80000000, 400000)
    finally:
        gcs.close()
        proc.terminate()  # the vehicle itself, as a service manager stops it
        try:
            assert proc.wait(10) == 0
        finally:
            kill_group(proc)
    assert main(["--sysid", "2", "--listen", "udpin:127.0.0.1:0", "--home", "95,0,0"]) == 2


def test_cli_stops_with_0_on_a_burst_of_sigints():
    """Ctrl-C under `ros2 launch` reaches the vehicle twice (the terminal's, then launch's);
    a later one, even while the interpreter shuts down, must not end it by the signal (exit
    -2, "process has died" in launch's log): SIGINT every 5 ms until it has ended."""
    import signal
    import subprocess
    import sys
    import time
    proc = subprocess.Popen([sys.executable, "-m", "uav_insar_sim.vehicle", "--sysid", "5",
                             "--listen", "udpin:127.0.0.1:0"], stdout=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        assert proc.stdout.readline().startswith("vehicle sysid 5 ")  # its handlers are set
        end = time.monotonic() + 10.0
        while proc.poll() is None and time.monotonic() < end:
            proc.send_signal(signal.SIGINT)
            time.sleep(0.005)
        assert proc.wait(1) == 0
    finally:
        kill_group(proc)
