"""`uav-insar montecarlo`: the Monte-Carlo check (montecarlo.py) of a planned or given formation.

Registered by cli/__init__.py (`add_parser`); bad input raises ParamError (one line, exit 2).
"""
from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable

import numpy as np

from uav_insar_planner.params import SCHEMES, ParamError, Params, shown

MAX_SAMPLES = 100_000_000
FORMATION_HELP = "x0,z0,x1,z1[,x2,z2]"


def add_parser(sub, add_scenario_args: Callable[[argparse.ArgumentParser], None]) -> None:
    m = sub.add_parser("montecarlo", help="Monte-Carlo of the InSAR measurement of a formation")
    add_scenario_args(m)
    m.add_argument("--scheme", choices=SCHEMES, help="as for solve (when planning)")
    m.add_argument("--formation", metavar=FORMATION_HELP,
                   help="simulate this formation (metres) instead of planning one")
    m.add_argument("--samples", default="100000", metavar="N",
                   help="pixels per pair (default 100000)")
    m.add_argument("--seed", default="0", metavar="S", help="random seed (default 0)")
    m.add_argument("--json", action="store_true", help="print one JSON object")
    m.add_argument("--plot", metavar="FILE.png",
                   help="height-error histograms per pair and fused against the model")


def parse_int(option: str, text: str, lo: int, hi: int) -> int:
    """An integer option in [lo, hi], else one ParamError line."""
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or not lo <= value <= hi:
        raise ParamError([f"{option}: value {shown(text)} is not allowed; expected an integer "
                          f"in [{lo}, {hi}]"])
    return value


def parse_formation(text: str) -> np.ndarray:
    """`x0,z0,x1,z1[,x2,z2]` -> (3, 2) rows, NaN for U2 when only 4 numbers; altitudes > 0."""
    bad = (f"--formation: value {shown(text)} is not allowed; expected {FORMATION_HELP}: "
           "4 or 6 finite numbers in metres, every altitude z_k > 0")
    try:
        nums = [float(t) for t in text.split(",")]
    except ValueError:
        raise ParamError([bad]) from None
    if len(nums) not in (4, 6) or not all(math.isfinite(v) for v in nums) \
            or not all(z > 0 for z in nums[1::2]):
        raise ParamError([bad])
    q = np.full((3, 2), np.nan)
    q[: len(nums) // 2] = np.reshape(nums, (-1, 2))
    return q


def _pairs(params: Params, formation: np.ndarray, text: str) -> dict:
    from uav_insar_planner.montecarlo import pairs_of_formation

    pairs = pairs_of_formation(params, formation)
    for name, pm in pairs.items():
        if not (np.isfinite(pm["h_amb_m"]) and 0.0 < pm["coherence_total"] < 1.0):
            raise ParamError([f"--formation: value {shown(text)} is not allowed; U0-U{name[-1]} "
                              "has no perpendicular baseline (h_amb infinite) or no coherence"])
    return pairs


def run(args: argparse.Namespace, scenario: Callable[[argparse.Namespace], Params]) -> int:
    """The subcommand: exit 0, 3 when the plan is infeasible, ParamError for bad input."""
    from uav_insar_planner.montecarlo import format_table, simulate

    samples = parse_int("--samples", args.samples, 2, MAX_SAMPLES)
    seed = parse_int("--seed", args.seed, 0, 2**63 - 1)
    formation = parse_formation(args.formation) if args.formation is not None else None
    if formation is not None and args.scheme:
        raise ParamError(["--scheme: not allowed with --formation (the formation is given)"])
    params = scenario(args)
    planned = None
    if formation is None:
        from uav_insar_planner.solver import solve

        plan = solve(params)
        if not plan.feasible:
            print("uav-insar: infeasible, blocked by: " + ", ".join(plan.blocking_constraints))
            return 3
        formation, planned = plan.formation, plan
    pairs = _pairs(params, formation, args.formation or "")
    result = simulate(pairs, params.looks, samples, seed, keep_samples=bool(args.plot))
    errors = result.pop("height_errors_m", None)
    head = {"source": "plan" if planned else "--formation",
            "formation": [[None if not np.isfinite(v) else float(v) for v in row]
                          for row in formation]}
    if planned is not None:
        head |= {"scheme": planned.scheme, "objective": planned.objective,
                 "sigma_h_planned_m": planned.sigma_h_m}
    if args.json:
        print(json.dumps(head | {"montecarlo": result}, indent=2))
    else:
        where = (f"planned formation ({planned.scheme}, objective {planned.objective}, "
                 f"planned sigma_h {planned.sigma_h_m:.5f} m)" if planned else "given formation")
        rows = ", ".join(f"U{k} ({x:.3f}, {z:.3f})" for k, (x, z) in enumerate(formation)
                         if np.isfinite(x))
        print(f"{where}: {rows}\n" + format_table(result))
    if args.plot:
        from uav_insar_planner.report.figures import plot_montecarlo

        plot_montecarlo(result | {"height_errors_m": errors}, args.plot)
        if not args.json:
            print(f"wrote {args.plot}")
    return 0
