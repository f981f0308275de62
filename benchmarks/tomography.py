"""The tomographic objective against the classic layouts, N = 4, 5, 6 receivers.

At the same Rayleigh resolution (tomo_resolution_m, Table I's geometry otherwise), three
arrays: equal spacing, Moffet's minimum-redundancy layout, and the objective's (objective
tomography, solver evolution: the relaxation's best shape, flown within C1, C3-C7, C9-C11 and
checked by the independent checker). For each: resolution, nearest ambiguity (AF >= 0.9),
PSLR and ISLR over |h| <= tomo_height_span_m; for the objective also the certified lower
bound on ISLR (the branch and bound on the geometry-free relaxation), whether it closed, and
the solve time. The layouts' figures come from tomography/array_factor.py alone; an array
whose ambiguity is below tomo_ambiguity_min_m is marked (it breaks the requirement).

Run: .venv/bin/python benchmarks/tomography.py [--budget 10] [--span 2.5] [--resolution 1]
[--ambiguity 2.5]
"""
from __future__ import annotations

import argparse
import time

from uav_insar_planner.params import default_params
from uav_insar_planner.solver import solve
from uav_insar_planner.tomography import bound as bound_module
from uav_insar_planner.tomography.array_factor import tomography_figures
from uav_insar_planner.tomography.design import equal_spacing, minimum_redundancy

SIZES = (4, 5, 6)
BASE_RATES_MBPS = (10.0, 16.95)  # Table I's U0 and U1; 1 Mbit/s for every further slave


def row(n: int, name: str, f, amb_min: float, extra: str = "| | |") -> str:
    amb = f.ambiguity_height_m
    mark = "" if amb is None or amb >= amb_min else " (below H)"
    amb_text = "none" if amb is None else f"{amb:.3f}{mark}"
    return (f"| {n} | {name} | {f.resolution_m:.4f} | {f.main_lobe_m:.3f} | {amb_text} | "
            f"{f.pslr_db:.2f} | {f.islr_db:.2f} {extra}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=float, default=bound_module.BOUND_TIME_S,
                    help="seconds of branch and bound per solve")
    ap.add_argument("--span", type=float, default=2.5)
    ap.add_argument("--resolution", type=float, default=1.0)
    ap.add_argument("--ambiguity", type=float, default=2.5)
    args = ap.parse_args()
    bound_module.BOUND_TIME_S = args.budget  # the solve's budget (a module constant)
    print(f"resolution {args.resolution} m, sidelobes over |h| <= {args.span} m, nearest "
          f"ambiguity required >= {args.ambiguity} m; bound budget {args.budget:g} s\n")
    print("| N | array | resolution (m) | main lobe h_1 (m) | nearest ambiguity (m) | "
          "PSLR (dB) | ISLR (dB) | ISLR bound (dB) | solve |")
    print("|---|---|---|---|---|---|---|---|---|")
    aperture = 1.0 / args.resolution
    for n in SIZES:
        print(row(n, "equal spacing", tomography_figures(equal_spacing(n, aperture), args.span),
                  args.ambiguity))
        print(row(n, "minimum redundancy", tomography_figures(
            minimum_redundancy(n, aperture), args.span), args.ambiguity))
        rates = list(BASE_RATES_MBPS) + [1.0] * (n - len(BASE_RATES_MBPS))
        p = default_params().replace(num_uavs=n, rate_min_mbps=rates, objective="tomography",
                                     solver="evolution", tomo_height_span_m=args.span,
                                     tomo_resolution_m=args.resolution,
                                     tomo_ambiguity_min_m=args.ambiguity)
        start = time.perf_counter()
        plan = solve(p)
        took = time.perf_counter() - start
        if not plan.feasible:
            print(f"| {n} | objective tomography | infeasible: {plan.message} | | | | | | |")
            continue
        t, obj = plan.metrics["tomography"], plan.metrics["tomography_objective"]
        b = obj["islr_lower_bound_db"]
        bound = "none proven" if b is None else (
            f"{b:.2f} ({'closed' if obj['bound_closed'] else 'open'})")
        f = tomography_figures(plan_kappa(t), args.span)
        print(row(n, "objective tomography (flown, checked)", f, args.ambiguity,
                  f"| {bound} | {took:.1f} s |"))


def plan_kappa(t: dict):
    """The plan's wavenumbers from its signed baselines (the resolution fixes the scale)."""
    import numpy as np

    b = np.asarray(t["b_perp_signed_m"])
    return b / (b.max() - b.min()) / t["resolution_m"]


if __name__ == "__main__":
    main()
