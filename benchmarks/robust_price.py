"""The price of robustness at Table I: nominal and worst-case sigma_h against nav_error_m.

For each navigation error e the robust plan (solver/robust.py) is solved and its figures
printed: sigma_h at the planned points, the certified worst case sigma_h_worst_m over the error
disks, the worst case against the nominal optimum (e = 0), the worst-case problem's lower bound
and gap, the solve time (the least of --repeat solves: the machine may be shared, and the
least is the one nearest a solve alone), and, as a check, the largest sigma_h of --samples
formations with each UAV moved within e (a third uniform in the disks, two thirds on their
rims) under the independent checker (evaluate.py) with the plan's power schedule, and how
many of them break a constraint other than C2.

Run: .venv/bin/python benchmarks/robust_price.py [--errors 0 0.1 0.25 0.5 1] [--samples 2000]
     [--repeat 3]
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import default_params
from uav_insar_planner.solver import solve


def sampled(plan, e: float, samples: int, rng: np.random.Generator) -> tuple[float, int]:
    """(largest sigma_h, formations breaking C1 or C3-C11) over `samples` moved formations."""
    p = default_params()
    n = len(plan.formation)
    worst, broken = 0.0, 0
    for i in range(samples):
        angle = rng.uniform(0.0, 2.0 * math.pi, n)
        radius = e * (np.sqrt(rng.uniform(0.0, 1.0, n)) if i % 3 == 0 else np.ones(n))
        q = plan.formation + np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)
        ev = evaluate(p, q, plan.p_com_w, plan.scheme)
        broken += bool(set(ev.violated) - {"C2"})
        worst = max(worst, ev.sigma_h)
    return worst, broken


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--errors", type=float, nargs="+", default=[0.0, 0.1, 0.25, 0.5, 1.0])
    parser.add_argument("--samples", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    rng = np.random.default_rng(29)
    nominal = solve(default_params()).sigma_h_m
    print("| e [m] | sigma_h [cm] | sigma_h_worst [cm] | worst / nominal optimum | "
          "lower bound [cm] | gap | sampled worst [cm] | broken | solve [s] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for e in args.errors:
        took = math.inf
        for _ in range(max(args.repeat, 1)):
            start = time.perf_counter()
            plan = solve(default_params().replace(nav_error_m=e))
            took = min(took, time.perf_counter() - start)
        if not plan.feasible:
            print(f"| {e:g} | infeasible: {', '.join(plan.blocking_constraints)} |")
            continue
        seen, broken = sampled(plan, e, args.samples, rng)
        lower = plan.worst_lower_bound_m if e > 0 else plan.lower_bound_m
        gap = plan.worst_gap if e > 0 else plan.optimality_gap
        print(f"| {e:g} | {plan.sigma_h_m * 100:.3f} | {plan.sigma_h_worst_m * 100:.3f} | "
              f"{plan.sigma_h_worst_m / nominal:.3f} | {lower * 100:.3f} | {gap:.2%} | "
              f"{seen * 100:.3f} | {broken}/{args.samples} | {took:.2f} |")


if __name__ == "__main__":
    main()
