"""Benchmark of the accuracy-speed front (survey/speed.py): warm-started vs cold, side by side.

Solves the certified optimum of Table I at the front's speeds (0.25..4.75 m/s by 0.25, then
5..8 m/s by 1, infeasible: 23 points) once warm-started along the front (`speed_front`) and
once each point cold (`warm=False`), interleaved over `--repeats` rounds after one untimed
solve (imports, caches). Prints each way's median wall time, the ratio warm / cold (target
<= 0.5) and whether both certify the same optimum at every point.

`--scan`: the measurement of survey/speed.py's docstring instead: sigma_h at 0.05..4.75 m/s by
0.05 (warm), whether each point's certified lower bound exceeds the previous sigma_h, the
feasibility edge bisected to 1e-4 m/s, and what blocks past it.

Run: .venv/bin/python benchmarks/survey_speed_front.py [--repeats 5] [--scan]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from uav_insar_planner.params_file import load_params
from uav_insar_planner.solver import solve
from uav_insar_planner.survey.speed import speed_front

SPEEDS = [float(v) for v in np.arange(0.25, 4.76, 0.25)] + [5.0, 6.0, 7.0, 8.0]


def front(repeats: int) -> None:
    p = load_params()
    solve(p)  # untimed: imports and caches
    times: dict[str, list[float]] = {"warm": [], "cold": []}
    fronts = {}
    for _ in range(repeats):
        for name, warm in (("warm", True), ("cold", False)):
            start = time.perf_counter()
            fronts[name] = speed_front(p, SPEEDS, warm=warm)
            times[name].append(time.perf_counter() - start)
    same = all(w.feasible == c.feasible and (not w.feasible or abs(w.sigma_h_m - c.sigma_h_m)
                                             <= 2e-4 * c.sigma_h_m)
               for w, c in zip(fronts["warm"], fronts["cold"], strict=True))
    warm, cold = (statistics.median(times[k]) for k in ("warm", "cold"))
    print(f"{len(SPEEDS)} speeds, {sum(q.feasible for q in fronts['cold'])} feasible, "
          f"median of {repeats} rounds")
    print(f"warm-started: {warm * 1e3:8.1f} ms  ({warm / len(SPEEDS) * 1e3:.1f} ms a point)")
    print(f"cold:         {cold * 1e3:8.1f} ms  ({cold / len(SPEEDS) * 1e3:.1f} ms a point)")
    print(f"warm / cold:  {warm / cold:.2f} (target <= 0.5); same optimum at every point: {same}")
    for w, c in zip(fronts["warm"], fronts["cold"], strict=True):
        print(f"  v {w.speed_mps:5.2f}  sigma_h {w.sigma_h_m:.6f}  gap {w.optimality_gap:.1e}  "
              f"warm {w.solve_time_s * 1e3:6.1f} ms  cold {c.solve_time_s * 1e3:6.1f} ms  "
              + " ".join(w.blocking))


def scan() -> None:
    p = load_params()
    speeds = [round(float(v), 2) for v in np.arange(0.05, 4.76, 0.05)]
    start = time.perf_counter()
    points = speed_front(p, speeds)
    print(f"{len(points)} warm solves at {speeds[0]}..{speeds[-1]} m/s in "
          f"{time.perf_counter() - start:.2f} s; infeasible: "
          f"{[q.speed_mps for q in points if not q.feasible]}")
    feasible = [q for q in points if q.feasible]
    rising = all(b.lower_bound_m > a.sigma_h_m for a, b in zip(feasible, feasible[1:],
                                                                strict=False))
    print(f"certified increasing (each lower bound > the previous sigma_h): {rising}")
    for v in (0.01, 0.5, 1.0, 2.0, 3.0, 4.3, 4.7, 4.75):
        print(f"  v {v:5.2f}  sigma_h {solve(p.replace(speed_mps=v)).sigma_h_m:.5f}")
    lo, hi = 4.7, 4.8
    while hi - lo > 1e-4:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if solve(p.replace(speed_mps=mid)).feasible else (lo, mid)
    print(f"feasibility edge in [{lo:.5f}, {hi:.5f}] m/s, sigma_h "
          f"{solve(p.replace(speed_mps=lo)).sigma_h_m:.5f} at {lo:.4f}")
    for v in (hi, 5.0, 10.0, 15.0, 15.5, 20.0, 30.0, 100.0, 1000.0):
        plan = solve(p.replace(speed_mps=v))
        print(f"  v {v:8.4f}  feasible {plan.feasible}  blocking "
              + " + ".join(plan.blocking_constraints))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--scan", action="store_true")
    args = parser.parse_args()
    scan() if args.scan else front(args.repeats)


if __name__ == "__main__":
    main()
