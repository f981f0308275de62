"""The scenario options every planning verb shares (`--params`, `--set`, `--objective`,
`--solver`, and on the science verbs `--paper`) and the Params they make: Table I, then the
file, then `--paper`'s values (PAPER_VALUES), then the overrides; and the one line that says
which problem's C10 was solved (`margin_line`)."""
from __future__ import annotations

import argparse

from uav_insar_planner.params import OBJECTIVES, PAPER_VALUES, SOLVERS, Params
from uav_insar_planner.params_file import load_params, parse_override

#: What `--paper` sets, as its help and the margin line name it: `rate_margin 0`.
PAPER_SETTINGS = ", ".join(f"{name} {value:g}" for name, value in PAPER_VALUES.items())


def add_scenario_arguments(parser: argparse.ArgumentParser, paper: bool = False) -> None:
    """Add `--params`, `--set`, `--objective` and `--solver` to `parser`; with `paper`, also
    `--paper` (the verbs that reproduce the paper: solve, sweep, map, plot-formation,
    montecarlo)."""
    parser.add_argument("--params", metavar="FILE", help="ROS 2 params file (default: Table I)")
    parser.add_argument("--set", metavar="NAME=VALUE", action="append", default=[],
                        help="override a parameter (repeatable), e.g. --set h_amb_min_m=0.9")
    parser.add_argument("--objective", choices=OBJECTIVES,
                        help="exact sigma_h, Prop. 1 bound, sigma_h with the exact "
                        "multilook phase std, or tomography (the array factor's ISLR)")
    parser.add_argument("--solver", choices=SOLVERS,
                        help="global (certified), paper-ao or evolution")
    if paper:
        parser.add_argument("--paper", action="store_true",
                            help="the paper's problem (P): every field-only default set back "
                            f"to the paper's value ({PAPER_SETTINGS}), over --params; an "
                            "explicit --set of the same name still wins")


def scenario_params(args: argparse.Namespace) -> Params:
    """The Params of the scenario options (and `--scheme`, where the verb has one; a verb
    without `--objective` or `--solver` keeps the file's); raises ParamError, one line per
    problem."""
    overrides = dict(parse_override(item) for item in args.set)
    for name in ("objective", "solver", "scheme"):  # the verbs that have them
        if getattr(args, name, None):
            overrides[name] = getattr(args, name)
    return load_params(args.params, overrides, paper=getattr(args, "paper", False))


def margin_line(margin: float, paper: bool = False) -> str:
    """The line that says once which C10 a solve or sweep held: the field problem's rate
    margin (its value read from the scenario), or the paper's R_min exactly. `paper`: --paper
    was given (so a margin came from an explicit --set, which wins)."""
    if margin == 0.0:
        return "rate margin 0: C10 holds R_min exactly (the paper's)"
    why = ("set explicitly, which wins over --paper" if paper
           else "the field problem; --paper solves the paper's")
    return (f"includes a {100 * margin:.3g} % rate margin (rate_margin {margin:g}: C10 at "
            f"{1 + margin:.3g} R_min, {why})")
