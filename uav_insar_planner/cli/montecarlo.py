"""`uav-insar montecarlo`: the Monte-Carlo check (montecarlo.py) of a planned or given formation.

Every input and the `--plot` path are checked before the plan and the simulation. Exit codes
(exit_codes.py): EXIT_OK, EXIT_INFEASIBLE when the plan to simulate is infeasible,
EXIT_BAD_INPUT, EXIT_CRASH when a solver fails.
"""
from __future__ import annotations

import argparse
import json
import math

import numpy as np

from uav_insar_planner.cli.checks import check_output_path
from uav_insar_planner.cli.scenario import add_scenario_arguments, scenario_params
from uav_insar_planner.exit_codes import EXIT_INFEASIBLE, EXIT_OK
from uav_insar_planner.params import LENGTH_MAX_M, SCHEMES, ParamError, Params, shown
from uav_insar_planner.swarm import MAX_UAVS, MIN_UAVS

HELP = "Monte-Carlo of the InSAR measurement of a formation"
# Memory: about 110 bytes per sample of a pair's run (both pairs, the fused figures and
# --plot's histograms; measured 1.1 GB at 10 million), so a run stays far inside 24 GB.
MAX_SAMPLES = 10_000_000
# Time: a sample draws 4 normals per look (montecarlo.multilook_phase); samples x looks is held
# to this per pair: about 15 s per pair on one core here (measured 140 s for two pairs of 1e9).
MAX_DRAWS = 200_000_000
SEED_MAX = 2**63 - 1
FORMATION_HELP = f"x0,z0,x1,z1[,...,x{MAX_UAVS - 1},z{MAX_UAVS - 1}]"
# the master and the first slave, then any more slaves in order: MIN_UAVS..MAX_UAVS UAVs
FORMATION_COUNTS = tuple(range(2 * MIN_UAVS, 2 * MAX_UAVS + 1, 2))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_scenario_arguments(parser, paper=True)
    parser.add_argument("--scheme", choices=SCHEMES, help="as for solve (when planning)")
    parser.add_argument("--formation", metavar=FORMATION_HELP,
                        help="simulate this formation (metres) instead of planning one")
    parser.add_argument("--samples", default="100000", metavar="N",
                        help="pixels per pair (default 100000)")
    parser.add_argument("--seed", default="0", metavar="S", help="random seed (default 0)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--plot", metavar="FILE.png",
                        help="height-error histograms per pair and fused against the model")


def parse_int(option: str, text: str, lo: int, hi: int, why: str = "") -> int:
    """An integer option in [lo, hi], else one ParamError line (`why` the reason for hi)."""
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or not lo <= value <= hi:
        raise ParamError([f"{option}: value {shown(text)} is not allowed; expected an integer "
                          f"in [{lo}, {hi}]{why}"])
    return value


def parse_samples(option: str, text: str, looks: int) -> int:
    """Samples per pair: 2..MAX_SAMPLES, and at most MAX_DRAWS / looks."""
    hi = min(MAX_SAMPLES, MAX_DRAWS // looks)
    why = f" (samples x looks <= {MAX_DRAWS:.0e} with looks {looks})" if hi < MAX_SAMPLES else ""
    return parse_int(option, text, 2, hi, why)


def parse_formation(text: str) -> np.ndarray:
    """`x0,z0,x1,z1[,...]` -> (n, 2) rows, one per UAV given (n in MIN_UAVS..MAX_UAVS, the
    master first); every number within +-LENGTH_MAX_M (as every length parameter), altitudes
    > 0."""
    counts = ", ".join(str(n) for n in FORMATION_COUNTS[:-1]) + f" or {FORMATION_COUNTS[-1]}"
    bad = (f"--formation: value {shown(text)} is not allowed; expected {FORMATION_HELP}: "
           f"{counts} finite numbers in metres, each within +-{LENGTH_MAX_M:g} m as every length, "
           "every altitude z_k > 0")
    try:
        nums = [float(t) for t in text.split(",")]
    except ValueError:
        raise ParamError([bad]) from None
    if len(nums) not in FORMATION_COUNTS or not all(math.isfinite(v) and abs(v) <= LENGTH_MAX_M
                                          for v in nums) or not all(z > 0 for z in nums[1::2]):
        raise ParamError([bad])
    return np.reshape(nums, (-1, 2))


def _pairs(params: Params, formation: np.ndarray, text: str) -> dict:
    from uav_insar_planner.montecarlo import pairs_of_formation

    pairs = pairs_of_formation(params, formation)
    for name, pm in pairs.items():
        if not (np.isfinite(pm["h_amb_m"]) and 0.0 < pm["coherence_total"] < 1.0):
            raise ParamError([f"--formation: value {shown(text)} is not allowed; U0-U{name[-1]} "
                              "has no perpendicular baseline (h_amb infinite) or no coherence"])
    return pairs


def main(args: argparse.Namespace) -> int:
    from uav_insar_planner.montecarlo import simulate

    params = scenario_params(args)
    samples = parse_samples("--samples", args.samples, params.looks)
    seed = parse_int("--seed", args.seed, 0, SEED_MAX)
    formation = parse_formation(args.formation) if args.formation is not None else None
    if formation is not None and args.scheme:
        raise ParamError(["--scheme: not allowed with --formation (the formation is given)"])
    if args.plot:
        check_output_path("--plot", args.plot, image=True)
    planned = None
    if formation is None:
        from uav_insar_planner.solver import solve

        plan = solve(params)
        if not plan.feasible:
            print("uav-insar: infeasible, blocked by: " + ", ".join(plan.blocking_constraints))
            return EXIT_INFEASIBLE
        formation, planned = plan.formation, plan
    pairs = _pairs(params, formation, args.formation or "")
    result = simulate(pairs, params.looks, samples, seed, keep_samples=bool(args.plot))
    errors = result.pop("height_errors_m", None)
    _print_result(result, formation, planned, args.json)
    if args.plot:
        from uav_insar_planner.report.figures import plot_montecarlo

        plot_montecarlo(result | {"height_errors_m": errors}, args.plot)
        if not args.json:
            print(f"wrote {args.plot}")
    return EXIT_OK


def _print_result(result: dict, formation: np.ndarray, planned, as_json: bool) -> None:
    from uav_insar_planner.montecarlo import format_table

    head = {"source": "plan" if planned else "--formation",
            "formation": [[None if not np.isfinite(v) else float(v) for v in row]
                          for row in formation]}
    if planned is not None:
        head |= {"scheme": planned.scheme, "objective": planned.objective,
                 "sigma_h_planned_m": planned.sigma_h_m}
    if as_json:
        print(json.dumps(head | {"montecarlo": result}, indent=2))
        return
    where = (f"planned formation ({planned.scheme}, objective {planned.objective}, "
             f"planned sigma_h {planned.sigma_h_m:.5f} m)" if planned else "given formation")
    rows = ", ".join(f"U{k} ({x:.3f}, {z:.3f})" for k, (x, z) in enumerate(formation)
                     if np.isfinite(x))
    print(f"{where}: {rows}\n" + format_table(result))
