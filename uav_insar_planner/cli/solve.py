"""`uav-insar solve`: solve problem (P) for one scenario and print the plan.

Exit codes (exit_codes.py): EXIT_OK solved, EXIT_INFEASIBLE when the scenario has no plan (the
blocking constraints are printed), EXIT_BAD_INPUT, EXIT_CRASH when a solver fails on an allowed
scenario.
"""
from __future__ import annotations

import argparse
import json
import math
import sys

from uav_insar_planner.cli.scenario import add_scenario_arguments, margin_line, scenario_params
from uav_insar_planner.exit_codes import EXIT_INFEASIBLE, EXIT_OK
from uav_insar_planner.params import SCHEMES, ParamError
from uav_insar_planner.swarm import uav_name

HELP = "solve problem (P) and print the plan"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(parser, paper=True)
    parser.add_argument("--scheme", choices=SCHEMES, help="proposed or benchmark 1-3")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--min-separation-m", type=float, default=None, metavar="M",
                        help="warn when two planned UAVs are closer than M metres (default "
                        "2.0: standard GNSS error; 0 turns the warning off)")


def main(args: argparse.Namespace) -> int:
    from uav_insar_planner.plan import SAFE_SEPARATION_M, closest_pair
    from uav_insar_planner.report.plan_text import format_plan
    from uav_insar_planner.solver import solve

    limit = SAFE_SEPARATION_M if args.min_separation_m is None else args.min_separation_m
    if not (limit >= 0.0 and math.isfinite(limit)):
        raise ParamError([f"--min-separation-m: value {limit!r} is not allowed; expected a "
                          "finite number >= 0"])
    params = scenario_params(args)
    plan = solve(params)
    price = margin_price(params, plan, solve, getattr(args, "paper", False))
    if args.json:
        print(json.dumps({**plan.to_dict(), "rate_margin": price}, indent=2))
    else:
        print(format_plan(plan))
        print(price["text"])
    closest = closest_pair(plan.formation) if plan.feasible else None
    if closest is not None and closest[0] < limit:
        d, j, k = closest
        print(f"uav-insar: warning: {uav_name(j)} and {uav_name(k)} are planned {d:.2f} m "
              f"apart, closer than {limit:g} m: with standard GNSS (1.5-3 m error) they may "
              "collide; fly RTK, raise d_min_m, or plan for the error with nav_error_m",
              file=sys.stderr)
    return EXIT_OK if plan.feasible else EXIT_INFEASIBLE


def margin_price(params, plan, solve, paper: bool = False) -> dict:
    """What the rate margin costs in sigma_h: `plan` (solved with params.rate_margin) against
    the same scenario solved at margin 0; {"margin", "sigma_h_m", "sigma_h_without_m",
    "price" (relative), "text"}. No second solve when the margin is 0."""
    mu = params.rate_margin
    out = {"margin": mu, "sigma_h_m": plan.sigma_h_m if plan.feasible else None,
           "sigma_h_without_m": None, "price": None}
    if mu == 0.0:
        return {**out, "text": margin_line(mu)}
    bare = solve(params.replace(rate_margin=0.0))
    if bare.feasible:
        out["sigma_h_without_m"] = bare.sigma_h_m
    head = f"{margin_line(mu, paper)}: "
    if plan.feasible and bare.feasible:
        out["price"] = plan.sigma_h_m / bare.sigma_h_m - 1.0
        text = (f"{head}sigma_h {plan.sigma_h_m * 100:.4g} cm, {bare.sigma_h_m * 100:.4g} cm "
                f"without it ({out['price']:+.2%})")
    elif bare.feasible:
        text = (f"{head}infeasible; without it feasible at sigma_h "
                f"{bare.sigma_h_m * 100:.4g} cm (--set rate_margin=0, or a smaller margin)")
    else:
        text = f"{head}infeasible with or without it"
    return {**out, "text": text}
