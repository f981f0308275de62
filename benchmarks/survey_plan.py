"""Benchmark: a 20-strip survey planned (survey/planning.py) against one Table I solve, side by
side in one run (issue 40's target: at most 3x).

The area is a rectangle 20 swaths wide (S_0 = 55 m, overlap 0.2: 20 strips) and 170 m long,
the ground station at its centre; the bearing is given (the layout across every degree,
`--bearing auto`, is timed too). Table I's link reaches a strip about 160 m across from the
station (C9), 4 strips' worth: the survey's scenario is Table I with a link for 900 m
(LINK: 30 dBW peak, 2 kJ, 5 Mbit/s each), and its own solve is timed beside Table I's. All
are timed `--repeats` times, interleaved, after one untimed run (imports, caches); the
medians and their ratios to the Table I solve are printed.

Run: .venv/bin/python benchmarks/survey_plan.py [--repeats 5]
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import time

from uav_insar_planner.mission_file.geodesy import ned_to_latlon
from uav_insar_planner.mission_file.qgc_plan import Home
from uav_insar_planner.params_file import load_params
from uav_insar_planner.solver import solve
from uav_insar_planner.survey.area import read_area
from uav_insar_planner.survey.planning import SurveyOptions, plan_survey

HOME = Home(48.1, 11.5, 520.0)
WIDTH_M = 55.0 + 19 * 0.8 * 55.0  # 20 bands of S_0 = 55 m at overlap 0.2
LENGTH_M = 170.0
LINK = {"p_com_max_db": 30.0, "e_com_max_j": 2000.0, "rate_min_mbps": [5.0, 5.0, 5.0]}


def area_text() -> str:
    corners = [(60.0, 20.0), (60.0 + LENGTH_M, 20.0), (60.0 + LENGTH_M, 20.0 + WIDTH_M),
               (60.0, 20.0 + WIDTH_M)]  # north, east: strips run north
    ring = [[ned_to_latlon(HOME.lat_deg, HOME.lon_deg, n, e)[1],
             ned_to_latlon(HOME.lat_deg, HOME.lon_deg, n, e)[0]] for n, e in corners]
    return json.dumps({"type": "Polygon", "coordinates": [ring + [ring[0]]]})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    repeats = parser.parse_args().repeats
    table_i, area = load_params(), read_area(area_text(), HOME)
    params = load_params(overrides=LINK)
    station = (60.0 + LENGTH_M / 2, 20.0 + WIDTH_M / 2)
    fixed = SurveyOptions(bearing_rad=0.0, station_ne_m=station, endurance_s=3600.0,
                          speed_mps=params.speed)
    auto = SurveyOptions(station_ne_m=station, endurance_s=3600.0, speed_mps=params.speed)
    runs = {"Table I solve": lambda: solve(table_i),
            "the survey's scenario solve": lambda: solve(params),
            "20-strip survey": lambda: plan_survey(area, params, fixed),
            "20-strip survey, bearing auto": lambda: plan_survey(area, params, auto)}
    for run in runs.values():
        run()  # untimed
    times: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(repeats):
        for name, run in runs.items():
            start = time.perf_counter()
            run()
            times[name].append(time.perf_counter() - start)
    survey = plan_survey(area, params, fixed)
    base = statistics.median(times["Table I solve"])
    print(f"survey: {len(survey.strips)} strips, {len(survey.sorties)} sorties, "
          f"{survey.covered_fraction:.1%} covered")
    for name, ts in times.items():
        med = statistics.median(ts)
        print(f"{name:32s} {1e3 * med:8.1f} ms  {med / base:6.2f} x the Table I solve")
    assert math.isfinite(base)


if __name__ == "__main__":
    main()
