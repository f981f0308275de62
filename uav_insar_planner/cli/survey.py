"""`uav-insar survey AREA`: plan the survey of an area (GeoJSON or KML polygon): the speed, one
certified formation, strips on the radar's look side with run-ins, sorties that fit a battery,
and write them for ground stations (survey/planning.py is the science; this is its adapter).

Into `--out` (made when missing): `survey.geojson` (the area, each strip's master track and
swath: QGIS, geojson.io), `survey.png` (the map), `survey.json` (the survey for the planner
node and `uav-insar report --survey`: survey/survey_file.py), and `sortie<S>_uav<K>.plan` per
sortie and flown UAV (QGroundControl; heights AMSL; mission_file/survey_plan.py). ArduPilot
files wait at each strip's entry for its UTC start: sortie 1 takes off at `--start-utc`
(default: now + qgc_plan.PREFLIGHT_S), each later one `--turnaround-min` after the one before
has landed; a sortie flown later is exported again with a later `--start-utc`. PX4 files hold
at each strip's entry until `uav-insar start-missions --item SEQ` (the sequence numbers are
printed, and in `--json`). Files are written to temporaries and renamed, and
`sortie*_uav*.plan` plans of an earlier, larger survey are removed (mission_file/folder.py): a
failed run leaves the folder as it was. `--front PNG` also plots the certified accuracy-time
front.

Exit codes (exit_codes.py): EXIT_OK; EXIT_BAD_INPUT (one line naming the field: not GeoJSON,
no polygon, a self-intersecting ring, an area too far from home, a sortie that holds no
strip, ...); EXIT_INFEASIBLE (no plan at the speed, no speed meeting the target, a strip the
ground station cannot serve: one line); EXIT_CRASH when a solver fails.
"""
from __future__ import annotations

import argparse
import json
import math
import re
import sys
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np

from uav_insar_planner.autopilots.profiles import AUTOPILOTS, profile
from uav_insar_planner.cli.checks import check_output_folder, utc_instant
from uav_insar_planner.cli.export_mission import (
    check_start,
    parse_bounded,
    parse_home,
    write_out,
)
from uav_insar_planner.cli.scenario import add_scenario_arguments, scenario_params
from uav_insar_planner.exit_codes import EXIT_INFEASIBLE, EXIT_OK
from uav_insar_planner.mission_file.folder import folder_problems
from uav_insar_planner.mission_file.geodesy import latlon_to_ned
from uav_insar_planner.mission_file.qgc_plan import PREFLIGHT_S
from uav_insar_planner.mission_file.survey_plan import StripLeg, sortie_document, sortie_items
from uav_insar_planner.params import ParamError, shown
from uav_insar_planner.swarm import uav_name

HELP = "plan the survey of an area: strips, sorties, speed; GeoJSON, map and .plan files"
AREA_MAX_BYTES = 10 << 20
SORTIES_MAX = 1000
STALE = re.compile(r"^sortie\d+_uav\d+\.plan$")
FRONT_POINTS = 12
FRONT_SPAN = 1.25  # the front's speeds: chosen / 1.25 .. chosen x 1.25


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(parser)
    parser.add_argument("area", metavar="AREA", help="GeoJSON (Polygon, or a Feature / "
                        "FeatureCollection of one) or KML file of the area, lon/lat")
    parser.add_argument("--home", required=True, metavar="LAT,LON,ALT",
                        help="take-off and landing: degrees, degrees, metres AMSL")
    parser.add_argument("--out", required=True, metavar="DIR", help="folder for the files")
    parser.add_argument("--station", metavar="LAT,LON", help="the ground station the radar "
                        "data is offloaded to (default: the home), at the scenario's g_z")
    parser.add_argument("--overlap", default="0.2", metavar="F",
                        help="between adjacent swaths, a fraction in [0, 1) (default 0.2)")
    parser.add_argument("--bearing", default="auto", metavar="auto|DEG",
                        help="the strips' direction from north (default auto: least time)")
    parser.add_argument("--endurance-min", default="20", metavar="M",
                        help="a battery's flight time in minutes (default 20)")
    parser.add_argument("--reserve", default="0.2", metavar="F",
                        help="of the endurance kept in reserve (default 0.2)")
    parser.add_argument("--speed", metavar="auto|M/S", help="v_y (default: the scenario's "
                        "speed_mps); auto with --sigma-h-max or --sorties")
    parser.add_argument("--sigma-h-max", metavar="M", help="--speed auto: the fastest speed "
                        "whose certified sigma_h is at most M metres")
    parser.add_argument("--sorties", metavar="N", help="--speed auto: the least sigma_h "
                        "whose survey fits in N sorties")
    parser.add_argument("--max-speed", default="15", metavar="M/S",
                        help="the airframe's top ground speed (default 15)")
    parser.add_argument("--autopilot", choices=AUTOPILOTS, default="ardupilot",
                        help="the .plan files' firmware (default ardupilot)")
    parser.add_argument("--start-utc", metavar="HH:MM:SS|ISO",
                        help="ArduPilot: sortie 1's take-off (default: now + "
                        f"{PREFLIGHT_S:g} s)")
    parser.add_argument("--turnaround-min", default="15", metavar="M",
                        help="ArduPilot: landing to the next take-off (default 15)")
    parser.add_argument("--front", metavar="PNG", help="also plot the accuracy-time front")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def _options(args: argparse.Namespace, home, params):
    from uav_insar_planner.survey.planning import SurveyOptions

    speed = None if args.speed == "auto" else (
        params.speed if args.speed is None else parse_bounded("--speed", args.speed, 0.01,
                                                              1000.0))
    station = (0.0, 0.0)
    if args.station is not None:
        lat, lon = _pair("--station", args.station)
        station = latlon_to_ned(home.lat_deg, home.lon_deg, lat, lon)
        if math.hypot(*station) > 10_000.0:
            raise ParamError([f"--station: value {shown(args.station)} is not allowed; "
                              "expected a station within 10 km of the home"])
    sigma = (None if args.sigma_h_max is None
             else parse_bounded("--sigma-h-max", args.sigma_h_max, 1e-6, 1e3))
    sorties = (None if args.sorties is None
               else int(parse_bounded("--sorties", args.sorties, 1, SORTIES_MAX)))
    if speed is not None and (sigma is not None or sorties is not None):
        raise ParamError(["--sigma-h-max / --sorties: not allowed with --speed M/S; expected "
                          "them with --speed auto"])
    bearing = (None if args.bearing == "auto"
               else math.radians(parse_bounded("--bearing", args.bearing, -360.0, 360.0)))
    try:
        return SurveyOptions(
            overlap=parse_bounded("--overlap", args.overlap, 0.0, 0.95),
            bearing_rad=bearing,
            endurance_s=60.0 * parse_bounded("--endurance-min", args.endurance_min, 0.1, 1e4),
            reserve=parse_bounded("--reserve", args.reserve, 0.0, 0.9), speed_mps=speed,
            sigma_h_max_m=sigma, sorties=sorties,
            max_speed_mps=parse_bounded("--max-speed", args.max_speed, 0.01, 1000.0),
            station_ne_m=station)
    except ValueError as exc:
        raise ParamError([str(exc)]) from None


def _pair(option: str, text: str) -> tuple[float, float]:
    bad = f"{option}: value {shown(text)} is not allowed; expected LAT,LON in degrees"
    try:
        lat, lon = (float(t) for t in text.split(","))
    except ValueError:
        raise ParamError([bad]) from None
    if not (math.isfinite(lat) and math.isfinite(lon) and abs(lat) <= 89 and abs(lon) <= 180):
        raise ParamError([bad])
    return lat, lon


def _read_area(path_text: str, home):
    from uav_insar_planner.survey.area import read_area

    path = Path(path_text)
    try:
        if path.stat().st_size > AREA_MAX_BYTES:
            raise ParamError([f"AREA: value {shown(path_text)} is not allowed; expected a "
                              f"file of at most {AREA_MAX_BYTES >> 20} MB"])
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise ParamError([f"AREA: value {shown(path_text)} is not allowed; it cannot be read "
                          f"({why}); expected a GeoJSON or KML file"]) from None
    try:
        return read_area(text, home)
    except ValueError as exc:
        raise ParamError([str(exc)]) from None


def _starts(args: argparse.Namespace, now: datetime) -> tuple[datetime | None, float]:
    """(sortie 1's take-off UTC for ArduPilot files, None for PX4; the turnaround [s])."""
    holds = not profile(args.autopilot).mission_waits_for_utc
    turnaround = 60.0 * parse_bounded("--turnaround-min", args.turnaround_min, 0.0, 1e4)
    if args.start_utc is None:
        if holds:
            return None, turnaround
        t = now + timedelta(seconds=PREFLIGHT_S)
        return t.replace(microsecond=0) + timedelta(seconds=1), turnaround
    if holds:
        raise ParamError([f"--start-utc: not allowed with --autopilot {args.autopilot} (it "
                          "ignores NAV_DELAY's UTC time; its UAVs hold at each strip until "
                          "`uav-insar start-missions --item SEQ`)"])
    start = utc_instant("--start-utc", args.start_utc, now)
    check_start(args.start_utc, start, now)
    return start, turnaround


def _plans(survey, args: argparse.Namespace, take_off: datetime | None, turnaround: float
           ) -> tuple[dict[str, str], dict[str, list[int]]]:
    """(.plan texts by file name, each file's MISSION_START items per strip (PX4))."""
    from uav_insar_planner.survey.sorties import strip_starts_s

    home, plan, fly = survey.area.home, survey.plan, survey.options.fly
    tracks = [sp.strip.track for sp in survey.strips]
    x0 = float(plan.formation[0, 0])
    texts, items = {}, {}
    for s, sortie in enumerate(survey.sorties):
        starts = strip_starts_s(tracks, sortie, survey.speed_mps, fly)
        legs = [StripLeg(survey.strips[i].strip.frame(x0), survey.strips[i].strip.track.length_m,
                         survey.run_in_m, None if take_off is None
                         else (take_off + timedelta(seconds=math.ceil(t))))
                for i, t in zip(sortie.strips, starts, strict=True)]
        for k, (x, z) in enumerate(plan.formation):
            if not (np.isfinite(x) and np.isfinite(z)):
                continue
            name = f"sortie{s + 1}_{uav_name(k)}.plan"
            texts[name] = json.dumps(sortie_document(
                home, legs, float(x), float(z), survey.speed_mps, fly.transit_mps,
                args.autopilot), indent=2) + "\n"
            items[name] = sortie_items(home, legs, float(x), float(z), survey.speed_mps,
                                       fly.transit_mps)[1]
        if take_off is not None:
            take_off += timedelta(seconds=math.ceil(sortie.flight_time_s + turnaround))
    return texts, items


def _summary(survey, items: dict[str, list[int]]) -> dict:
    return {"strips": len(survey.strips),
            "sorties": [{"strips": list(s.strips), "flight_time_s": round(s.flight_time_s, 1)}
                        for s in survey.sorties],
            "speed_mps": survey.speed_mps, "speed_why": survey.speed_why,
            "sigma_h_m": survey.plan.sigma_h_m, "lower_bound_m": survey.plan.lower_bound_m,
            "total_time_s": round(survey.total_time_s, 1), "area_m2": survey.area.area_m2,
            "covered_fraction": survey.covered_fraction,
            "bearing_deg": math.degrees(survey.bearing_rad), "swath_m": survey.swath_m,
            "run_in_m": survey.run_in_m, "mission_start_items": items}


def main(args: argparse.Namespace) -> int:
    import io

    from uav_insar_planner.report.survey_map import plot_front, plot_survey
    from uav_insar_planner.survey.geojson import survey_geojson
    from uav_insar_planner.survey.planning import SurveyInfeasible, accuracy_time_front, plan_survey
    from uav_insar_planner.survey.speed import SpeedSearchError
    from uav_insar_planner.survey.survey_file import survey_document

    now = datetime.now(timezone.utc)
    params = scenario_params(args)
    home = parse_home(args.home)
    options = _options(args, home, params)
    take_off, turnaround = _starts(args, now)
    if not args.out.strip():
        raise ParamError(["--out: value '' is not allowed; expected a folder, e.g. survey"])
    out = Path(args.out)
    check_output_folder("--out", out)
    if args.front is not None:
        from uav_insar_planner.cli.checks import check_output_path
        check_output_path("--front", args.front, image=True)
    area = _read_area(args.area, home)
    try:
        survey = plan_survey(area, params, options)
    except (SurveyInfeasible, SpeedSearchError) as exc:
        print(f"uav-insar: infeasible: {exc}", file=sys.stderr)
        return EXIT_INFEASIBLE
    except ValueError as exc:
        raise ParamError([str(exc)]) from None
    texts, items = _plans(survey, args, take_off, turnaround)
    texts["survey.geojson"] = json.dumps(survey_geojson(survey), indent=1) + "\n"
    texts["survey.json"] = json.dumps(survey_document(survey, params), indent=1) + "\n"
    png = io.BytesIO()
    plot_survey(survey, png)
    files: dict[str, str | bytes] = {**texts, "survey.png": png.getvalue()}
    stale = ([p.name for p in out.iterdir() if STALE.match(p.name) and p.name not in files]
             if out.is_dir() else [])
    if problems := folder_problems("--out", out, files, stale):
        raise ParamError(problems)
    removed = write_out(args.out, out, files, stale)
    if args.front is not None:
        # about the chosen speed, where the trade is made (the scenario's plans end near it)
        top = min(options.max_speed_mps, FRONT_SPAN * survey.speed_mps)
        speeds = sorted({*np.linspace(top / FRONT_SPAN ** 2, top, FRONT_POINTS),
                         survey.speed_mps})
        plot_front(accuracy_time_front(area, params, options, speeds), survey.speed_mps,
                   args.front)
    summary = _summary(survey, items if take_off is None else {})
    if args.json:
        print(json.dumps(summary))
        return EXIT_OK
    for s, sortie in enumerate(survey.sorties):
        print(f"sortie {s + 1}: strips {', '.join(map(str, sortie.strips))}, "
              f"{sortie.flight_time_s / 60:.1f} min of flight")
    print(f"{len(survey.strips)} strips, bearing {summary['bearing_deg']:.0f} deg, swath "
          f"{survey.swath_m:.1f} m, v_y {survey.speed_mps:.3f} m/s ({survey.speed_why}), "
          f"sigma_h {survey.plan.sigma_h_m:.4f} m; {survey.covered_fraction:.1%} of "
          f"{survey.area.area_m2:.0f} m2 covered; {survey.total_time_s / 60:.1f} min in all")
    if take_off is None:
        print("each UAV holds at each strip's entry until `uav-insar start-missions --item SEQ "
              "CONNECTION...`; SEQ per file and strip: " + json.dumps(items))
    print(f"wrote {len(files)} files into {out}" + (
        f"; removed {', '.join(removed)} (an earlier survey's)" if removed else ""))
    return EXIT_OK
