"""`uav-insar export-mission`: one QGroundControl `.plan` per flown UAV, for autopilots that fly
the pass on their own (no companion computer, no ROS): take off, wait at the pass start until
one UTC time common to all UAVs (ArduPilot) or until `uav-insar start-missions` (PX4), fly the
pass at v_y, hold or return (mission_file/qgc_plan).

The formation is the solved plan's (default) or `--formation`'s, as `uav-insar montecarlo`
takes it; a given one must meet C1 and C4 (evaluate.position_constraints: altitudes within
[z_min_m, z_max_m], every two UAVs d_min_m apart), else it is refused naming the worst. `--home`
is the track origin (x = y = 0 on the ground), `--bearing` points the along-track axis y.
`--start-utc` must be at least START_LEAD_MIN_S ahead. `--out` is a folder, made (with its
parents) when missing; `uavK.plan` files in it are replaced, and those of UAVs this export
does not fly (left by an earlier export of more UAVs) are removed and named, if they are
QGroundControl plans; anything else in the way is refused (mission_file/folder.py). Every
input and every target is checked before the plan is solved; the files are written to
temporaries and renamed, so a failed export leaves the folder as it was. Exit codes
(exit_codes.py): EXIT_OK, EXIT_BAD_INPUT, EXIT_INFEASIBLE (the blocking constraints are
printed), EXIT_CRASH when a solver fails.
"""
from __future__ import annotations

import argparse
import json
import math
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np

from uav_insar_planner.autopilots.profiles import AUTOPILOTS, profile
from uav_insar_planner.cli.checks import check_output_folder, utc_instant
from uav_insar_planner.cli.montecarlo import FORMATION_HELP, parse_formation
from uav_insar_planner.cli.scenario import add_scenario_arguments, scenario_params
from uav_insar_planner.evaluate import position_constraints
from uav_insar_planner.exit_codes import EXIT_INFEASIBLE, EXIT_OK
from uav_insar_planner.mission_file.folder import folder_problems, replace_files
from uav_insar_planner.mission_file.geodesy import POLE_MARGIN_DEG
from uav_insar_planner.mission_file.qgc_plan import (
    ALTITUDE_FRAMES,
    ENDS,
    PX4_PASS_SEQ,
    RUN_UP_S,
    START_LEAD_MIN_S,
    Home,
    Pass,
    default_start,
    plan_document,
)
from uav_insar_planner.params import LENGTH_MAX_M, SCHEMES, ParamError, Params, shown
from uav_insar_planner.schemes import active_uavs
from uav_insar_planner.swarm import MAX_UAVS, uav_name, uavs

HELP = "write a QGroundControl .plan per UAV (the pass without a companion computer)"
HOME_ALT_MAX_M = 1.0e4
BEARING_MAX_DEG = 360.0
LAT_MAX_DEG = 90.0 - POLE_MARGIN_DEG


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
                        "time to arm, climb and reach the start. ArduPilot only: PX4 ignores "
                        "NAV_DELAY's time, its UAVs hold until `uav-insar start-missions`")
    parser.add_argument("--end", choices=ENDS, default="hold",
                        help="after the pass: hold at its end (default) or return to launch")
    parser.add_argument("--autopilot", choices=AUTOPILOTS, default="ardupilot",
                        help="the plan's firmwareType (default ardupilot); px4: each UAV holds "
                        f"at its start until MISSION_START with first item {PX4_PASS_SEQ} "
                        "(`uav-insar start-missions`)")
    parser.add_argument("--altitude-frame", choices=tuple(ALTITUDE_FRAMES), default="amsl",
                        help="amsl (default): heights AMSL, --home's altitude + z_k, right "
                        "wherever a UAV is armed; relative: z_k above each UAV's own home, "
                        "right only if every UAV arms at --home's altitude")
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


def _planned(params: Params) -> np.ndarray | None:
    """The solved plan's formation; None (the blocking constraints printed) if infeasible."""
    from uav_insar_planner.solver import solve

    plan = solve(params)
    if not plan.feasible:
        print("uav-insar: infeasible, blocked by: " + ", ".join(plan.blocking_constraints))
        return None
    return plan.formation


def check_flyable(text: str, formation: np.ndarray, params: Params) -> None:
    """One ParamError line unless the given formation meets C1 and C4 (evaluate's
    position_constraints): what the vehicles can fly at all. The measurement's constraints
    (C2, C3, C5-C8) are the planner's; a formation given by hand may trade them."""
    status = position_constraints(params, formation, uavs(len(formation)))
    broken = []
    if not status["C1"].ok:
        k = int(status["C1"].detail[1:])
        broken.append(f"C1: z{k} = {formation[k, 1]:g} m is outside [z_min_m, z_max_m] = "
                      f"[{params.z_min:g}, {params.z_max:g}] m")
    if not status["C4"].ok:
        i, j = (int(c) for c in status["C4"].detail[1:])
        broken.append(f"C4: U{i} and U{j} are {params.d_min + status['C4'].slack:.3g} m apart, "
                      f"less than d_min_m = {params.d_min:g} m")
    if broken:
        raise ParamError([f"--formation: value {shown(text)} is not allowed; "
                          f"{'; '.join(broken)}; expected every altitude in [z_min_m, z_max_m] "
                          "and every two UAVs at least d_min_m apart"])


def check_start(text: str, start: datetime, now: datetime) -> None:
    """One ParamError line when `start` is less than START_LEAD_MIN_S ahead of `now`."""
    if start - now < timedelta(seconds=START_LEAD_MIN_S):
        raise ParamError([f"--start-utc: value {shown(text)} is not allowed; expected at least "
                          f"{START_LEAD_MIN_S:g} s from now (now {now:%H:%M:%S} UTC), time "
                          "to upload, arm and reach the starts: an ArduPilot UAV that arrives "
                          "late waits a day"])


def check_out(text: str, names: list[str], stale: list[str]) -> Path:
    """The --out folder, with every file to write and every stale name checked: ParamError,
    one line per problem, before anything is solved or written."""
    if not text.strip():
        raise ParamError(["--out: value '' is not allowed; expected a folder (made when "
                          "missing), e.g. plans"])
    out = Path(text)
    check_output_folder("--out", out)
    if problems := folder_problems("--out", out, names, stale):
        raise ParamError(problems)
    return out


def write_out(text: str, out: Path, files: dict[str, str | bytes], stale: list[str]
              ) -> list[str]:
    """`files` written into the --out folder `out` (given as `text`) and the `stale` names
    removed, all or nothing (mission_file/folder.py): the names removed, or one ParamError
    line saying nothing was changed."""
    try:
        return replace_files(out, files, stale)
    except OSError as exc:
        raise ParamError([f"--out: value {shown(text)} is not allowed; writing "
                          f"{shown(exc.filename)} failed ({exc.strerror}); nothing was "
                          "changed"]) from None


def plan_names(count: int) -> list[str]:
    """The file names of UAVs 0..count - 1."""
    return [f"{uav_name(k)}.plan" for k in uavs(count)]


def main(args: argparse.Namespace) -> int:
    now = datetime.now(timezone.utc)
    params = scenario_params(args)
    home = parse_home(args.home)
    bearing = parse_bounded("--bearing", args.bearing, -BEARING_MAX_DEG, BEARING_MAX_DEG)
    run_up = (RUN_UP_S * params.speed if args.run_up_m is None
              else parse_bounded("--run-up-m", args.run_up_m, 0.0, LENGTH_MAX_M))
    start = (utc_instant("--start-utc", args.start_utc, now) if args.start_utc is not None
             else None)
    if args.formation is not None and args.scheme:
        raise ParamError(["--scheme: not allowed with --formation (the formation is given)"])
    holds = not profile(args.autopilot).mission_waits_for_utc  # until MISSION_START
    if holds and start is not None:
        raise ParamError([f"--start-utc: not allowed with --autopilot {args.autopilot} (it "
                          "ignores NAV_DELAY's UTC time; give the instant to `uav-insar "
                          "start-missions --at`)"])
    if start is not None:
        check_start(args.start_utc, start, now)
    given = parse_formation(args.formation) if args.formation is not None else None
    if given is not None:
        check_flyable(args.formation, given, params)
    flying = (uavs(len(given)) if given is not None
              else active_uavs(params.scheme, params.num_uavs))
    names = [plan_names(MAX_UAVS)[k] for k in flying]
    stale = [name for name in plan_names(MAX_UAVS) if name not in names]
    out = check_out(args.out, names, stale)
    formation = given if given is not None else _planned(params)
    if formation is None:
        return EXIT_INFEASIBLE
    flown = {k: (float(formation[k, 0]), float(formation[k, 1])) for k in uavs(len(formation))
             if np.all(np.isfinite(formation[k]))}
    if start is None and not holds:
        start = default_start(now, flown, run_up)
    flight = Pass(params.speed, params.num_slots * params.slot_duration_s * params.speed,
                  run_up, bearing)
    texts = {f"{uav_name(k)}.plan": json.dumps(plan_document(
        home, flight, x, z, start, args.end, args.autopilot, args.altitude_frame), indent=2)
        + "\n" for k, (x, z) in flown.items()}
    stale = [name for name in plan_names(MAX_UAVS) if name not in texts]
    removed = write_out(args.out, out, texts, stale)
    for k, (x, z) in flown.items():
        print(f"wrote {out / (uav_name(k) + '.plan')}: x {x:.3f} m, z {z:.3f} m")
    if removed:
        print(f"removed {', '.join(removed)} from {out}: stale files of an earlier export "
              f"(this one flies {len(flown)} UAVs)")
    heights = (f"heights AMSL (z + {home.alt_m:g} m)" if args.altitude_frame == "amsl" else
               "heights above each UAV's home: arm every UAV at the home's altitude")
    when = ("each UAV holds at its start until `uav-insar start-missions --at HH:MM:SS "
            "CONNECTION...` starts them together (the autopilot ignores NAV_DELAY's UTC time)"
            if holds
            else f"passes start at {start:%Y-%m-%dT%H:%M:%SZ} (UTC)")
    print(f"{when}; {flight.length_m:g} m at {flight.speed_mps:g} m/s after a {run_up:g} m "
          f"run-up; bearing {bearing:g} deg; {heights}")
    return EXIT_OK
