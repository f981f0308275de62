"""`uav-insar export-mission`: one QGroundControl `.plan` per flown UAV, for autopilots that fly
the pass on their own (no companion computer, no ROS): take off, wait at the pass start until
one UTC time common to all UAVs, fly the pass at v_y, hold or return (mission_file/qgc_plan).

The formation is the solved plan's (default) or `--formation`'s, as `uav-insar montecarlo`
takes it. `--home` is the track origin (x = y = 0 on the ground), `--bearing` points the
along-track axis y. `--out` is a folder, made (with its parents) when missing; `uavK.plan`
files in it are replaced. Every input is checked before the plan is solved and nothing is
written unless all files can be. Exit codes (exit_codes.py): EXIT_OK, EXIT_BAD_INPUT,
EXIT_INFEASIBLE (the blocking constraints are printed), EXIT_CRASH when a solver fails.
"""
from __future__ import annotations

import argparse
import json
import math
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np

from uav_insar_planner.cli.checks import check_output_folder
from uav_insar_planner.cli.montecarlo import FORMATION_HELP, parse_formation
from uav_insar_planner.cli.scenario import add_scenario_arguments, scenario_params
from uav_insar_planner.exit_codes import EXIT_INFEASIBLE, EXIT_OK
from uav_insar_planner.mission_file.geodesy import POLE_MARGIN_DEG
from uav_insar_planner.mission_file.qgc_plan import (
    ENDS,
    FIRMWARE_TYPES,
    RUN_UP_S,
    Home,
    Pass,
    default_start,
    plan_document,
)
from uav_insar_planner.params import LENGTH_MAX_M, SCHEMES, ParamError, shown
from uav_insar_planner.swarm import uav_name

HELP = "write a QGroundControl .plan per UAV (the pass without a companion computer)"
HOME_ALT_MAX_M = 1.0e4
BEARING_MAX_DEG = 360.0
LAT_MAX_DEG = 90.0 - POLE_MARGIN_DEG
START_AHEAD_MAX = timedelta(hours=24)  # NAV_DELAY holds an hour of day, not a date


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(parser)
    parser.add_argument("--home", required=True, metavar="LAT,LON,ALT",
                        help="track origin: degrees, degrees, metres AMSL")
    parser.add_argument("--bearing", required=True, metavar="DEG",
                        help="direction of the along-track axis y from north, clockwise")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="folder for uav0.plan, uav1.plan, ... (made if missing)")
    parser.add_argument("--scheme", choices=SCHEMES, help="as for solve (when planning)")
    parser.add_argument("--formation", metavar=FORMATION_HELP,
                        help="fly this formation (metres) instead of planning one")
    parser.add_argument("--start-utc", metavar="HH:MM:SS|ISO",
                        help="when the passes start (UTC; HH:MM:SS is today); default: now + "
                        "time to arm, climb and reach the start")
    parser.add_argument("--end", choices=ENDS, default="hold",
                        help="after the pass: hold at its end (default) or return to launch")
    parser.add_argument("--autopilot", choices=tuple(FIRMWARE_TYPES), default="ardupilot",
                        help="the plan's firmwareType (default ardupilot)")
    parser.add_argument("--run-up-m", metavar="M",
                        help=f"start this far before y = 0 to reach v_y (default {RUN_UP_S:g} s "
                        "of v_y)")


def _numbers(option: str, text: str, count: int, expected: str) -> list[float]:
    bad = f"{option}: value {shown(text)} is not allowed; expected {expected}"
    try:
        nums = [float(t) for t in text.split(",")]
    except ValueError:
        raise ParamError([bad]) from None
    if len(nums) != count or not all(math.isfinite(v) for v in nums):
        raise ParamError([bad])
    return nums


def parse_home(text: str) -> Home:
    """`LAT,LON,ALT` -> Home; latitude within +-LAT_MAX_DEG, longitude within +-180,
    altitude within +-HOME_ALT_MAX_M."""
    expected = (f"LAT,LON,ALT: latitude within +-{LAT_MAX_DEG:g} deg (east offsets lose their "
                f"meaning at the poles), longitude within +-180 deg, altitude AMSL within "
                f"+-{HOME_ALT_MAX_M:g} m")
    lat, lon, alt = _numbers("--home", text, 3, expected)
    if abs(lat) > LAT_MAX_DEG or abs(lon) > 180.0 or abs(alt) > HOME_ALT_MAX_M:
        raise ParamError([f"--home: value {shown(text)} is not allowed; expected {expected}"])
    return Home(lat, lon, alt)


def parse_bounded(option: str, text: str, lo: float, hi: float) -> float:
    """A finite number in [lo, hi], else one ParamError line."""
    (value,) = _numbers(option, text, 1, f"a finite number in [{lo:g}, {hi:g}]")
    if not lo <= value <= hi:
        raise ParamError([f"{option}: value {shown(text)} is not allowed; expected a finite "
                          f"number in [{lo:g}, {hi:g}]"])
    return value


def parse_start(text: str, now: datetime) -> datetime:
    """`HH:MM:SS` (today, UTC) or an ISO 8601 time (UTC unless it has an offset) -> an aware
    UTC datetime in (now, now + 24 h), whole seconds."""
    bad = (f"--start-utc: value {shown(text)} is not allowed; expected HH:MM:SS (UTC, today) "
           "or an ISO 8601 time, whole seconds, after now and less than 24 h ahead (now "
           f"{now:%Y-%m-%dT%H:%M:%SZ})")
    try:
        if text.count(":") == 2 and "T" not in text and " " not in text.strip():
            t = datetime.combine(now.date(), datetime.strptime(text, "%H:%M:%S").time())
        else:
            t = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        raise ParamError([bad]) from None
    t = t.replace(tzinfo=timezone.utc) if t.tzinfo is None else t.astimezone(timezone.utc)
    if t.microsecond or not now < t < now + START_AHEAD_MAX:
        raise ParamError([bad])
    return t


def _formation(args: argparse.Namespace, params) -> np.ndarray | None:
    if args.formation is not None:
        return parse_formation(args.formation)
    from uav_insar_planner.solver import solve

    plan = solve(params)
    if not plan.feasible:
        print("uav-insar: infeasible, blocked by: " + ", ".join(plan.blocking_constraints))
        return None
    return plan.formation


def main(args: argparse.Namespace) -> int:
    now = datetime.now(timezone.utc)
    params = scenario_params(args)
    home = parse_home(args.home)
    bearing = parse_bounded("--bearing", args.bearing, -BEARING_MAX_DEG, BEARING_MAX_DEG)
    run_up = (RUN_UP_S * params.speed if args.run_up_m is None
              else parse_bounded("--run-up-m", args.run_up_m, 0.0, LENGTH_MAX_M))
    start = parse_start(args.start_utc, now) if args.start_utc is not None else None
    if args.formation is not None and args.scheme:
        raise ParamError(["--scheme: not allowed with --formation (the formation is given)"])
    out = Path(args.out)
    check_output_folder("--out", out)
    formation = _formation(args, params)
    if formation is None:
        return EXIT_INFEASIBLE
    flown = {k: (float(formation[k, 0]), float(formation[k, 1])) for k in range(len(formation))
             if np.all(np.isfinite(formation[k]))}
    if start is None:
        start = default_start(now, flown, run_up)
    flight = Pass(params.speed, params.num_slots * params.slot_duration_s * params.speed,
                  run_up, bearing)
    texts = {k: json.dumps(plan_document(home, flight, x, z, start, args.end, args.autopilot),
                           indent=2) + "\n" for k, (x, z) in flown.items()}
    out.mkdir(parents=True, exist_ok=True)
    for k, text in texts.items():
        (out / f"{uav_name(k)}.plan").write_text(text)
        x, z = flown[k]
        print(f"wrote {out / (uav_name(k) + '.plan')}: x {x:.3f} m, z {z:.3f} m")
    print(f"passes start at {start:%Y-%m-%dT%H:%M:%SZ} (UTC), {flight.length_m:g} m at "
          f"{flight.speed_mps:g} m/s after a {run_up:g} m run-up; bearing {bearing:g} deg")
    return EXIT_OK
