"""`uav-insar plot-formation`: solve one scenario and draw its across-track plane (or, with
`--psf`, its elevation array factor: report/array_factor_plot.py).

The `--out` image path is checked before the solve. Exit codes (exit_codes.py): EXIT_OK
written, EXIT_INFEASIBLE (nothing drawn, the blocking constraints named), EXIT_BAD_INPUT,
EXIT_CRASH when a solver fails.
"""
from __future__ import annotations

import argparse
import sys

from uav_insar_planner.cli.checks import check_output_path
from uav_insar_planner.cli.scenario import add_scenario_arguments, scenario_params
from uav_insar_planner.exit_codes import EXIT_INFEASIBLE, EXIT_OK
from uav_insar_planner.params import SCHEMES, ParamError

HELP = "draw the across-track plane"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(parser, paper=True)
    parser.add_argument("--scheme", choices=SCHEMES)
    parser.add_argument("--out", default="formation.png", metavar="FILE.png")
    parser.add_argument("--psf", action="store_true",
                        help="draw the elevation array factor (tomography, 3 or more UAVs) "
                        "instead of the plane")


def main(args: argparse.Namespace) -> int:
    from uav_insar_planner.report.figures import plot_formation
    from uav_insar_planner.solver import solve

    params = scenario_params(args)
    check_output_path("--out", args.out, image=True)
    plan = solve(params)
    if not plan.feasible:
        print("infeasible, blocked by: " + ", ".join(plan.blocking_constraints),
              file=sys.stderr)
        return EXIT_INFEASIBLE
    if args.psf:
        from uav_insar_planner.report.array_factor_plot import plot_array_factor

        try:
            plot_array_factor(params, plan, args.out)
        except ValueError as exc:
            raise ParamError([str(exc)]) from exc
    else:
        plot_formation(params, plan, args.out)
    print(f"wrote {args.out}")
    return EXIT_OK
