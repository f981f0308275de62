"""The scenario options every planning verb shares (`--params`, `--set`, `--objective`,
`--solver`) and the Params they make: Table I, then the file, then the overrides."""
from __future__ import annotations

import argparse

from uav_insar_planner.params import OBJECTIVES, SOLVERS, Params
from uav_insar_planner.params_file import load_params, parse_override


def add_scenario_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `--params`, `--set`, `--objective` and `--solver` to `parser`."""
    parser.add_argument("--params", metavar="FILE", help="ROS 2 params file (default: Table I)")
    parser.add_argument("--set", metavar="NAME=VALUE", action="append", default=[],
                        help="override a parameter (repeatable), e.g. --set h_amb_min_m=0.9")
    parser.add_argument("--objective", choices=OBJECTIVES,
                        help="exact sigma_h, Prop. 1 bound, sigma_h with the exact "
                        "multilook phase std, or tomography (the array factor's ISLR)")
    parser.add_argument("--solver", choices=SOLVERS,
                        help="global (certified), paper-ao or evolution")


def scenario_params(args: argparse.Namespace) -> Params:
    """The Params of the scenario options (and `--scheme`, where the verb has one; a verb
    without `--objective` or `--solver` keeps the file's); raises ParamError, one line per
    problem."""
    overrides = dict(parse_override(item) for item in args.set)
    for name in ("objective", "solver", "scheme"):  # the verbs that have them
        if getattr(args, name, None):
            overrides[name] = getattr(args, name)
    return load_params(args.params, overrides)
