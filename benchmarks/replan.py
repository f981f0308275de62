"""Wall time of the planner's re-plan after a lost slave (replan.replan_without: the reduced
single-baseline problem from slot n0 with the energy left, checked and mapped back) against
the full Table I solve, per solver, side by side. Not a test: prints a table.

The planner's promise is a new `formation` within 1 s of uav_timeout_s; the re-plan's solve is
most of the time between detection and publication.

Run: .venv/bin/python benchmarks/replan.py [--runs 5]
"""
from __future__ import annotations

import argparse
import statistics
import time

from uav_insar_planner.params import default_params
from uav_insar_planner.replanning import plans
from uav_insar_planner.solver import solve


def median_s(fn, runs: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    print(f"{'solver':9s} {'lost':5s} {'n0':>3s} {'re-plan ms':>11s} {'full ms':>8s} "
          f"{'ratio':>6s} feasible")
    for solver in ("global", "paper-ao"):
        p = default_params().replace(solver=solver)
        plan = solve(p)
        full = median_s(lambda p=p: solve(p), args.runs)
        for lost, survivor in ((1, 2), (2, 1)):
            for n0 in (0, 40, 70):
                energy = {k: plans.energy_left_j(p, plan.p_com_w, k, n0) for k in range(3)}

                def run(p=p, power=plan.p_com_w, lost=lost, survivor=survivor, n0=n0,
                        energy=energy):
                    return plans.replan_without(p, power, lost, (survivor,), n0, energy)

                t = median_s(run, args.runs)
                new, _ = run()
                print(f"{solver:9s} uav{lost}  {n0:3d} {t * 1e3:11.1f} {full * 1e3:8.1f} "
                      f"{t / full:6.2f} {new.feasible}")


if __name__ == "__main__":
    main()
