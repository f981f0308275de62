"""Benchmark of the Monte-Carlo check and the multilook objective, side by side.

Prints: the time of `montecarlo.simulate` at the Table I formation for 1e5 samples per pair
(two pairs, statistics included; target: well under a second) for several n_L, with the time
per pair; the time to build the exact multilook table per n_L; the median solve time of the
multilook objective against the exact (Cramer-Rao) objective with their ratio, per scheme; and
along Figure 3's axis (h_amb_min 0.5..2.0 m, 16 points, q0_fixed = (-54, 74) m) the largest
distance between the two objectives' formations, for every scheme.

Run: .venv/bin/python benchmarks/montecarlo.py [--repeats 5]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from uav_insar_planner import multilook
from uav_insar_planner.montecarlo import pairs_of_formation, simulate
from uav_insar_planner.params import SCHEMES, default_params
from uav_insar_planner.solver import solve


def timings(fn, repeats: int) -> list[float]:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return times


def median(fn, repeats: int) -> float:
    return statistics.median(timings(fn, repeats))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    p = default_params()
    pairs = pairs_of_formation(p, solve(p).formation)

    print(f"Monte-Carlo, Table I formation, 1e5 samples per pair, 2 pairs, {args.repeats} runs:")
    for looks in (1, 4, 16, 64):
        multilook.phase_std(0.5, looks)  # the table is built once per n_L, not timed here
        ts = timings(lambda n=looks: simulate(pairs, n, 100_000, seed=0), args.repeats)
        t, best = statistics.median(ts), min(ts)
        print(f"  n_L = {looks:3d}: median {t * 1e3:7.1f} ms, best {best * 1e3:7.1f} ms  "
              f"(median {t * 5e2:6.1f} ms per pair; target: well under 1000 ms per pair)")

    print("exact multilook table (built once per n_L and process):")
    for looks in (1, 4, 32, 256):
        multilook._table.cache_clear()
        t = median(lambda n=looks: multilook._table(n), 1)
        print(f"  n_L = {looks:3d}: {t:6.2f} s")

    print(f"solve time, median of {args.repeats}: multilook objective vs exact (Cramer-Rao)")
    multilook.phase_std(0.5, p.looks)
    for scheme in SCHEMES:
        te = median(lambda s=scheme: solve(p, scheme=s, objective="exact"), args.repeats)
        tm = median(lambda s=scheme: solve(p, scheme=s, objective="multilook"), args.repeats)
        gap = solve(p, scheme=scheme, objective="multilook").optimality_gap
        print(f"  {scheme:<16} exact {te * 1e3:7.1f} ms  multilook {tm * 1e3:7.1f} ms  "
              f"ratio {tm / te:4.2f}  multilook gap {gap:.1e}")

    print("Figure 3 axis (h_amb_min 0.5..2.0 m, 16 points): largest |formation difference| "
          "between the objectives' optima")
    base = p.replace(master_fixed_xz_m=[-54.0, 74.0])
    for scheme in SCHEMES:
        worst = 0.0
        for h in np.linspace(0.5, 2.0, 16):
            q = base.replace(h_amb_min_m=float(h))
            a = solve(q, scheme=scheme, objective="exact").formation
            b = solve(q, scheme=scheme, objective="multilook").formation
            worst = max(worst, float(np.nanmax(np.abs(a - b))))
        print(f"  {scheme:<16} {worst:.2e} m")


if __name__ == "__main__":
    main()
