"""Hostile and careless input to the SITL-style vehicle, over loopback UDP from a
bare pymavlink ground station: every bad value is refused with the right MAV_RESULT or
ignored, counted, and the position never turns NaN; bad command lines are one line and exit
2; a vehicle loop that dies is recorded and makes the program exit 1."""
import math
import sys
import time
from pathlib import Path

import process_group
import pytest
from mavlink_fakes import MAV, FakePeer, wait_until

from uav_insar_sim.vehicle.cli import main
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(60)
NAN, INF = float("nan"), float("inf")
DENIED = MAV.MAV_RESULT_DENIED
FAULT = Path(__file__).with_name("fault_injection.py")


@pytest.fixture
def rig():
    vehicle = SimVehicle(5, "udpin:127.0.0.1:0", "ardupilot", start_ned=(0.0, 0.0, -10.0),
                         airborne=True)
    vehicle.start()
    gcs = FakePeer(255, 191, dest=("127.0.0.1", vehicle.port), heartbeat_hz=2.0,
                   mav_type=MAV.MAV_TYPE_GCS, autopilot=MAV.MAV_AUTOPILOT_INVALID)
    gcs.wait_for("HEARTBEAT", 3.0)
    yield vehicle, gcs
    gcs.close()
    vehicle.stop()


def ack(gcs, cmd, params, since, timeout=2.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = [m for _, m in gcs.messages("COMMAND_ACK", since) if m.command == cmd]
        if found:
            return found[0].result
        time.sleep(0.01)
    raise AssertionError(f"no COMMAND_ACK for {cmd} {params}")


def setpoint(gcs, mask, position, velocity=(0.0, 0.0, 0.0)):
    gcs.mav.send(gcs.mav.set_position_target_local_ned_encode(
        0, 5, 1, MAV.MAV_FRAME_LOCAL_NED, mask, *position, *velocity, 0, 0, 0, 0, 0))


@pytest.mark.parametrize("mask, position, velocity", [
    (3576, (INF, 0.0, -5.0), (0.0, 0.0, 0.0)),       # position only, x = Inf
    (3576, (0.0, 0.0, NAN), (0.0, 0.0, 0.0)),        # position only, z = NaN
    (3520, (0.0, 0.0, -5.0), (NAN, 0.0, 0.0)),       # position + velocity, vx = NaN
    (3527, (0.0, 0.0, 0.0), (0.0, -INF, 0.0)),       # velocity only, vy = -Inf
    (0, (1.0, 2.0, -5.0), (0.0, 0.0, NAN)),          # mask 0 uses every field
])
def test_a_setpoint_with_a_used_non_finite_field_is_refused_and_counted(rig, mask, position,
                                                                      velocity):
    vehicle, gcs = rig
    for _ in range(3):
        setpoint(gcs, mask, position, velocity)
    assert wait_until(lambda: vehicle.stats.bad_value == 3, 2.0)
    assert vehicle.setpoints_rejected == 3 and vehicle.setpoints_accepted == 0
    time.sleep(0.3)
    assert all(math.isfinite(c) for c in vehicle.position_ned + vehicle.velocity_ned)
    assert vehicle.alive and vehicle.errors == 0


def test_ignored_fields_may_be_nan_as_px4_and_ardupilot_allow(rig):
    vehicle, gcs = rig
    setpoint(gcs, 3576, (3.0, 0.0, -10.0), (NAN, NAN, NAN))  # velocity ignored
    setpoint(gcs, 3527, (NAN, INF, NAN), (1.0, 0.0, 0.0))    # position ignored
    assert wait_until(lambda: vehicle.setpoints_accepted == 2, 2.0)
    assert vehicle.stats.bad_value == 0
    time.sleep(0.5)
    assert vehicle.velocity_ned[0] > 0.2 and all(math.isfinite(c) for c in vehicle.position_ned)


NAN7, INF7 = (NAN,) * 7, (INF,) * 7


@pytest.mark.parametrize("cmd, params", [
    (MAV.MAV_CMD_COMPONENT_ARM_DISARM, INF7),
    (MAV.MAV_CMD_COMPONENT_ARM_DISARM, NAN7),  # arm is required
    (MAV.MAV_CMD_DO_SET_MODE, NAN7),
    (MAV.MAV_CMD_DO_SET_MODE, (1.0, INF, 0, 0, 0, 0, 0)),
    (MAV.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, 0, 0, 0, INF)),
    (MAV.MAV_CMD_SET_MESSAGE_INTERVAL, (32, NAN, 0, 0, 0, 0, 0)),
    (MAV.MAV_CMD_SET_MESSAGE_INTERVAL, (32, INF, 0, 0, 0, 0, 0)),
    (MAV.MAV_CMD_SET_MESSAGE_INTERVAL, (32, -5.0, 0, 0, 0, 0, 0)),
    (MAV.MAV_CMD_SET_MESSAGE_INTERVAL, (32, 3e38, 0, 0, 0, 0, 0)),
    (MAV.MAV_CMD_SET_MESSAGE_INTERVAL, (NAN, 1e5, 0, 0, 0, 0, 0)),
    (MAV.MAV_CMD_REQUEST_MESSAGE, INF7),
])
def test_garbage_command_parameters_are_denied_counted_and_change_nothing(rig, cmd, params):
    vehicle, gcs = rig
    before = (vehicle.mode, vehicle.armed)
    since = time.monotonic()
    gcs.mav.send(gcs.mav.command_long_encode(5, 1, cmd, 0, *params))
    assert ack(gcs, cmd, params, since) == DENIED
    assert vehicle.stats.bad_value == 1 and vehicle.errors == 0
    assert (vehicle.mode, vehicle.armed) == before
    t0 = time.monotonic()
    time.sleep(0.5)  # LOCAL_POSITION_NED (id 32) still at 10 Hz: no interval was changed
    assert len(gcs.messages("LOCAL_POSITION_NED", t0)) >= 3
    assert all(math.isfinite(c) for c in vehicle.position_ned)


def test_every_command_survives_nan_and_inf_in_every_parameter(rig):
    vehicle, gcs = rig
    handled = (400, 176, 22, 21, 20, 511, 512, 410, 520, 12345)
    for cmd in handled:
        for params in (NAN7, INF7, (-INF,) * 7, (3e38,) * 7):
            since = time.monotonic()
            gcs.mav.send(gcs.mav.command_long_encode(5, 1, cmd, 0, *params))
            ack(gcs, cmd, params, since)
    assert vehicle.alive and vehicle.errors == 0
    assert all(math.isfinite(c) for c in vehicle.position_ned)


def test_param_set_nan_is_ignored_and_counted(rig):
    vehicle, gcs = rig
    speed = vehicle._ap.max_speed
    for value in (NAN, INF):
        gcs.mav.send(gcs.mav.param_set_encode(5, 1, b"WPNAV_SPEED", value,
                                              MAV.MAV_PARAM_TYPE_REAL32))
    assert wait_until(lambda: vehicle.stats.bad_value == 2, 2.0)
    assert vehicle._ap.max_speed == speed


def test_setpoints_and_commands_from_another_sysid_are_counted_and_ignored(rig):
    vehicle, _ = rig
    stranger = FakePeer(99, 191, dest=("127.0.0.1", vehicle.port))
    try:
        stranger.mav.send(stranger.mav.set_position_target_local_ned_encode(
            0, 5, 1, MAV.MAV_FRAME_LOCAL_NED, 3576, 50.0, 50.0, -50.0, 0, 0, 0, 0, 0, 0, 0, 0))
        stranger.mav.send(stranger.mav.command_long_encode(5, 1, 21, 0, *[0.0] * 7))
        assert wait_until(lambda: vehicle.stats.foreign == 2, 2.0)
        assert vehicle.setpoints_accepted == 0 and vehicle.mode == "GUIDED"
    finally:
        stranger.close()


@pytest.mark.parametrize("args, words", [
    (["--offboard-timeout", "nan"], "offboard_timeout_s: value nan"),
    (["--offboard-timeout", "-1"], "offboard_timeout_s: value -1.0"),
    (["--speed", "inf"], "max_speed: value inf"),
    (["--start-ned", "0", "1e39", "0"], "start_ned"),
    (["--listen", "udpout:no.such.host.invalid:14550"], "does not resolve"),
    (["--signing-key-file", "/no/such/key"], "signing key file"),
])
def test_bad_command_line_is_one_line_and_exit_2(capsys, args, words):
    argv = ["--sysid", "2", "--listen", "udpin:127.0.0.1:0", *args]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err


def test_a_dead_vehicle_loop_is_recorded_not_silent(rig):
    """FAULT INJECTION: the vehicle's link raises inside its loop (as a bug would)."""
    vehicle, _ = rig
    assert vehicle.alive

    def broken():
        raise RuntimeError("fault injection: the link raised")

    vehicle._link.poll = broken
    assert wait_until(lambda: vehicle.failure is not None, 2.0)
    assert "fault injection" in vehicle.failure and not vehicle.alive


def test_the_vehicle_program_exits_1_when_its_loop_dies():
    """FAULT INJECTION (test/fault_injection.py): its link starts raising after 1 s."""
    out = process_group.run([sys.executable, str(FAULT), "1.0", "uav_insar_sim.vehicle.cli",
                          "--sysid", "2", "--listen", "udpin:127.0.0.1:0"],
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 1, out
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "vehicle loop died" in lines[0], out.stderr


def test_a_flood_of_bad_input_is_one_log_line_per_kind():
    lines = []
    with SimVehicle(5, "udpin:127.0.0.1:0", "ardupilot", airborne=True,
                    start_ned=(0.0, 0.0, -10.0), log=lines.append) as vehicle:
        stranger = FakePeer(99, 191, dest=("127.0.0.1", vehicle.port))
        gcs = FakePeer(255, 191, dest=("127.0.0.1", vehicle.port))
        try:
            for _ in range(50):
                setpoint(stranger, 3576, (1.0, 2.0, -3.0))
                setpoint(gcs, 3576, (NAN, 2.0, -3.0))
            assert wait_until(lambda: vehicle.stats.foreign == 50
                              and vehicle.stats.bad_value == 50, 3.0)
        finally:
            stranger.close()
            gcs.close()
    assert len(lines) == 2, lines
    assert any("dropped foreign" in line and "sysid 99" in line for line in lines)
    assert any("dropped bad_value" in line for line in lines)
