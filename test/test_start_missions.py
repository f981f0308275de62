"""`uav-insar start-missions`: MISSION_START to every vehicle at one UTC instant, over real
MAVLink bytes (UDP on loopback) to the project's vehicle simulator in its PX4 and ArduPilot
flavours (in this process, each on a port of its own that the OS picks: no fixed ports).

Checked: three PX4-like vehicles, each with its `export-mission --autopilot px4` file uploaded
over the MAVLink mission protocol (its pass begins at item PX4_PASS_SEQ, after the hold), get
MISSION_START with that first item within TOLERANCE_S of the instant, and the command (run as
a process, as a user runs it) reports each ACCEPTED and exits 0; a vehicle that is silent at
the instant means nothing is sent to any (exit 1); ArduPilot's refusal of a first item and a
vehicle without a mission are reported (exit 1); bad input is one line, exit 2, before a byte
is sent.
"""
from __future__ import annotations

import json
import sys
import time
from datetime import datetime, timedelta, timezone
from pathlib import Path

import process_group
import pytest
from pymavlink import mavutil
from test_export_mission import export, mission_item_ints

from uav_insar_planner.cli import main as cli
from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_CRASH, EXIT_OK
from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.mission_file.qgc_plan import PX4_PASS_SEQ

CLI = [sys.executable, "-m", "uav_insar_planner.cli"]
TOLERANCE_S = 0.05  # arrival against the instant, on one machine's clock
LEAD_S = 4.0  # from now to the instant: the command's start-up and the heartbeats fit in it


def instant_in(seconds: float) -> datetime:
    """A whole UTC second at least `seconds` ahead."""
    t = datetime.now(timezone.utc) + timedelta(seconds=seconds)
    return t.replace(microsecond=0) + timedelta(seconds=1)


def upload(port: int, sysid: int, rows: list[tuple]) -> None:
    """The MAVLink mission upload of `rows` (MISSION_ITEM_INT fields) to the vehicle."""
    m = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255)
    try:
        m.mav.mission_count_send(sysid, 1, len(rows), 0)
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            msg = m.recv_match(type=["MISSION_REQUEST_INT", "MISSION_ACK"], blocking=True,
                               timeout=1.0)
            if msg is None:
                continue
            if msg.get_type() == "MISSION_ACK":
                assert msg.type == MAV.MAV_MISSION_ACCEPTED, msg
                return
            f, cmd, p1, p2, p3, p4, x, y, z = rows[msg.seq]
            m.mav.mission_item_int_send(sysid, 1, msg.seq, f, cmd, 0, 1, p1, p2, p3, p4, x,
                                        y, z, 0)
        raise AssertionError("mission upload timed out")
    finally:
        m.close()


def px4_rows(plan: Path) -> list[tuple]:
    """A PX4 file's items as MAVSDK uploads them to PX4: no home item first."""
    return mission_item_ints(json.loads(plan.read_text()))[1:]


@pytest.mark.timeout(60)
def test_three_px4_vehicles_start_at_the_instant(tmp_path, vehicles):
    assert export(tmp_path, "--autopilot", "px4") == EXIT_OK
    fleet = [vehicles("px4", 2 + k) for k in range(3)]
    for k, vehicle in enumerate(fleet):
        rows = px4_rows(tmp_path / f"uav{k}.plan")
        assert [r[1] for r in rows[PX4_PASS_SEQ - 1:PX4_PASS_SEQ + 2]] == [
            MAV.MAV_CMD_NAV_LOITER_UNLIM, MAV.MAV_CMD_DO_CHANGE_SPEED, MAV.MAV_CMD_NAV_WAYPOINT]
        upload(vehicle.port, vehicle.sysid, rows)
        assert len(vehicle.mission.items) == len(rows)
    at = instant_in(LEAD_S)
    proc = process_group.run([*CLI, "start-missions", "--at", f"{at:%H:%M:%S}" if at.date() ==
                              datetime.now(timezone.utc).date() else at.isoformat(),
                              *(f"udpout:127.0.0.1:{v.port}" for v in fleet)],
                             capture_output=True, text=True, timeout=30)
    assert proc.returncode == EXIT_OK, proc
    assert proc.stdout.count("MAV_RESULT_ACCEPTED") == 3, proc.stdout
    offsets = {}
    for vehicle in fleet:
        (arrival, first, result), = vehicle.mission_starts
        assert (first, result) == (PX4_PASS_SEQ, MAV.MAV_RESULT_ACCEPTED)
        offsets[vehicle.sysid] = round(arrival - at.timestamp(), 4)
    print("MISSION_START arrival after the instant [s]:", offsets)
    assert all(0.0 <= v < TOLERANCE_S for v in offsets.values()), offsets


@pytest.mark.timeout(30)
def test_a_vehicle_silent_at_the_instant_means_nothing_is_sent(vehicles, capsys):
    heard, silent = vehicles("px4", 2), vehicles("px4", 3)
    silent.set_radio(False)
    at = instant_in(2.0)
    assert cli(["start-missions", "--at", at.isoformat(), f"udpout:127.0.0.1:{heard.port}",
                f"udpout:127.0.0.1:{silent.port}"]) == EXIT_CRASH
    out = capsys.readouterr().out
    assert "nothing sent" in out and "no autopilot HEARTBEAT" in out, out
    assert not heard.mission_starts and not silent.mission_starts
    assert not any(c == MAV.MAV_CMD_MISSION_START for c, _ in heard.commands)


@pytest.mark.timeout(30)
def test_refusals_are_reported_per_vehicle(tmp_path, vehicles, capsys):
    """ArduCopter refuses a first item (its files wait on NAV_DELAY); PX4 without a mission
    refuses; a PX4 vehicle with its mission starts."""
    assert export(tmp_path, "--autopilot", "px4") == EXIT_OK
    ardu, empty, good = vehicles("ardupilot", 2), vehicles("px4", 3), vehicles("px4", 4)
    upload(ardu.port, ardu.sysid, px4_rows(tmp_path / "uav0.plan"))
    upload(good.port, good.sysid, px4_rows(tmp_path / "uav1.plan"))
    at = instant_in(2.0)
    assert cli(["start-missions", "--at", at.isoformat(),
                *(f"udpout:127.0.0.1:{v.port}" for v in (ardu, empty, good))]) == EXIT_CRASH
    lines = [""] + capsys.readouterr().out.splitlines()[-3:]
    assert "MAV_RESULT_DENIED" in lines[1] and "sysid 2" in lines[1], lines
    assert "MAV_RESULT_DENIED" in lines[2] and "sysid 3" in lines[2], lines
    assert "MAV_RESULT_ACCEPTED" in lines[3] and "sysid 4" in lines[3], lines
    assert [r for _, _, r in ardu.mission_starts] == [MAV.MAV_RESULT_DENIED]
    assert [r for _, _, r in good.mission_starts] == [MAV.MAV_RESULT_ACCEPTED]


# (--at, further arguments, what the error names); GOOD is the listening vehicle's link
BAD = [
    ("25:00:00", [], "--at"), ("12:00", [], "--at"), ("PAST", [], "--at"), ("FAR", [], "--at"),
    ("FRACTION", [], "--at"), (None, ["--item", "x"], "--item"), (None, ["--item=-1"], "--item"),
    (None, ["--item", "70000"], "--item"), (None, ["--source-sysid", "0"], "--source-sysid"),
    (None, ["udp:nohostport"], "CONNECTION 2"), (None, ["/tmp/flight.tlog"], "CONNECTION 2"),
    (None, ["/dev/ttyUSB0,fast"], "CONNECTION 2"),
    (None, ["udpout:no-such-host.invalid:14550"], "CONNECTION 2"),
    (None, ["GOOD"], "given twice"),
]


@pytest.mark.parametrize(("at", "extra", "named"), BAD,
                         ids=[f"{b[2]}{i}" for i, b in enumerate(BAD)])
def test_bad_input_is_one_line_exit_2_and_nothing_sent(vehicles, capsys, at, extra, named):
    vehicle = vehicles("px4", 2)
    good = f"udpout:127.0.0.1:{vehicle.port}"
    now = datetime.now(timezone.utc)
    at = {"PAST": (now - timedelta(seconds=5)).isoformat(),
          "FAR": (now + timedelta(hours=25)).isoformat(),
          "FRACTION": (now + timedelta(seconds=60.5)).isoformat(),
          None: instant_in(60).isoformat()}.get(at, at)
    argv = ["start-missions", "--at", at, good, *(good if a == "GOOD" else a for a in extra)]
    assert cli(argv) == EXIT_BAD_INPUT, argv
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and named in err, err
    time.sleep(0.1)
    assert vehicle.stats.rx_bytes == 0, vehicle.stats


@pytest.mark.timeout(30)
def test_a_link_lost_after_the_heartbeats_is_retried_then_reported(vehicles, capsys):
    """Heard, then silent from 1 s before the instant: MISSION_START goes out TRIES times,
    ACK_TIMEOUT_S apart, and the vehicle is reported without an ACK (exit 1)."""
    import threading

    from uav_insar_planner.mavlink.mission_start import ACK_TIMEOUT_S, TRIES

    vehicle = vehicles("px4", 2)
    at = instant_in(3.0)
    cut = threading.Timer(at.timestamp() - 1.0 - time.time(), vehicle.set_radio, (False,))
    cut.start()
    try:
        assert cli(["start-missions", "--at", at.isoformat(),
                    f"udpout:127.0.0.1:{vehicle.port}"]) == EXIT_CRASH
        done = time.time()
    finally:
        cut.cancel()
    line = capsys.readouterr().out.splitlines()[-1]
    assert f"({TRIES} tries), no COMMAND_ACK" in line and "sysid 2" in line, line
    assert (TRIES - 0.5) * ACK_TIMEOUT_S < done - at.timestamp() < (TRIES + 1) * ACK_TIMEOUT_S
    assert not vehicle.mission_starts
