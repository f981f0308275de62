"""`uav-insar map NAME1 START STOP COUNT NAME2 START STOP COUNT`: solve on the grid of two
parameters for several schemes, a parameter map.

Both names, ranges and counts are checked as `sweep` checks its one (checks.py, sweep.py), and
COUNT1 x COUNT2 x the schemes at most checks.MAP_SOLVES_MAX solves; every cell's scenario,
both output paths and where to solve (`--jobs`, `--scheduler`; cli/execution.py) are checked
before the first solve. Prints per scheme how many cells are feasible and the least sigma_h;
`--csv` writes one row per (value1, value2, scheme) with the sweep CSV's columns, `--plot` a
heat map of sigma_h per scheme (infeasible cells red). Exit codes (exit_codes.py): EXIT_OK (an
infeasible cell is a row, not a failure), EXIT_BAD_INPUT, EXIT_CRASH when a solver fails.
"""
from __future__ import annotations

import argparse

from uav_insar_planner.cli.checks import (
    MAP_SOLVES_MAX,
    check_output_path,
    finite_float,
    sweep_count,
)
from uav_insar_planner.cli.execution import add_execution_arguments, solving
from uav_insar_planner.cli.output import whole_file
from uav_insar_planner.cli.scenario import add_scenario_arguments, scenario_params
from uav_insar_planner.exit_codes import EXIT_OK
from uav_insar_planner.params import SCHEMES, ParamError

HELP = "solve on the grid of two parameters for several schemes (a heat map)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    for k in ("1", "2"):
        parser.add_argument("name" + k, help=f"parameter {k}, e.g. h_amb_min_m or "
                            "rate_min_mbps[1]")
        parser.add_argument("start" + k, type=finite_float, help="first value (file unit)")
        parser.add_argument("stop" + k, type=finite_float, help="last value")
        parser.add_argument("count" + k, type=sweep_count,
                            help="number of evenly spaced values")
    add_scenario_arguments(parser, paper=True)
    parser.add_argument("--schemes", nargs="+", choices=SCHEMES, default=list(SCHEMES),
                        help="schemes to solve in each cell (default: all four)")
    parser.add_argument("--csv", metavar="FILE", help="write one row per (value1, value2, "
                        "scheme)")
    parser.add_argument("--plot", metavar="FILE.png", help="heat map of sigma_h per scheme")
    add_execution_arguments(parser)


def main(args: argparse.Namespace) -> int:
    import numpy as np

    from uav_insar_planner.study.grid import map_params, run_map, write_map_csv

    params = scenario_params(args)
    solves = args.count1 * args.count2 * len(args.schemes)
    if solves > MAP_SOLVES_MAX:
        raise ParamError([f"map: COUNT1 x COUNT2 x schemes = {args.count1} x {args.count2} x "
                          f"{len(args.schemes)} = {solves} solves is not allowed; expected at "
                          f"most {MAP_SOLVES_MAX}"])
    if args.name1 == args.name2:
        raise ParamError([f"map NAME2: value {args.name2!r} is not allowed; expected a "
                          "parameter other than NAME1"])
    if args.csv:
        check_output_path("--csv", args.csv)
    if args.plot:
        check_output_path("--plot", args.plot, image=True)
    # every cell's scenario is validated before the first solve
    cells = map_params(params, args.name1, np.linspace(args.start1, args.stop1, args.count1),
                       args.name2, np.linspace(args.start2, args.stop2, args.count2))
    with solving(args, solves) as (run, bar):
        rows = run_map(cells, args.schemes, progress=bar.update, run=run)
    for scheme in args.schemes:
        ok = [r for r in rows if r.point.scheme == scheme and r.point.feasible]
        best = min(ok, key=lambda r: r.point.sigma_h_m) if ok else None
        print(f"{scheme:<16} {len(ok)}/{args.count1 * args.count2} cells feasible"
              + (f"; least sigma_h {best.point.sigma_h_m:.5f} m at {args.name1}="
                 f"{best.value1:.4g}, {args.name2}={best.value2:.4g}" if best else ""))
    if args.csv:
        with whole_file(args.csv) as tmp:
            write_map_csv(rows, tmp, args.name1, args.name2)
        print(f"wrote {args.csv}")
    if args.plot:
        from uav_insar_planner.report.figures import plot_map

        with whole_file(args.plot) as tmp:
            plot_map(rows, args.name1, args.name2, tmp)
        print(f"wrote {args.plot}")
    return EXIT_OK
