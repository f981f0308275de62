"""Benchmark of the certified global solver against the number of slaves K = num_uavs - 1.

Scenario: Table I (config/params.yaml) with the swarm grown or shrunk to K + 1 UAVs; UAVs
beyond Table I's three get U2's rate requirement (1 Mbit/s), so they are interchangeable with
U2 (the search orders their angles). The UAV count comes from the length of the per-UAV rate
list (problem.make_problem), the convention Params.num_uavs follows.

--slaves-at-1: every slave at 1 Mbit/s (U1 too; issue 29's ten-UAV case, K = 9).

Prints, in one run: per K the median solve time of solve_global (proposed scheme, exact
objective, at most --budget seconds of branch and bound) over --repeats runs (one run from
K = 6), its ratio to K = 2 and to K - 1, the boxes searched, sigma_h, the certified lower
bound, the gap and whether the certificate is complete (every box closed, gap <= 1e-4); then
per K up to --grid-max-k the slowest of the twelve scheme x objective solves and the largest
gap among them; and the targets (K = 2 median <= 10 ms through the public `solve` with the
Table I plan unchanged, K = 5 median <= 1 s, K = 9 certified within 10 s, every gap <= 1e-4).

--baselines adds, per K, one solve each of paper-ao and evolution through the public `solve`
(so the independent checker sees every plan): time, sigma_h and its ratio to the global
solver's (the K = 2..9 table of docs/science/solvers.md).

--baseline SRC also times Table I (K = 2) with the package found under SRC (e.g. an export of
main: git archive main | tar -x -C /tmp/main) in a subprocess and prints the ratio.

Run: .venv/bin/python benchmarks/global_solver_k.py [--repeats 9] [--max-k 9] [--budget 10]
     [--slaves-at-1] [--baselines] [--grid-max-k 5] [--no-grid] [--baseline SRC]
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import subprocess
import sys
import time

from uav_insar_planner.params import SCHEMES, Params, default_params
from uav_insar_planner.solver import solve
from uav_insar_planner.solver.global_opt.optimum import solve_global
from uav_insar_planner.swarm import MAX_UAVS

OBJECTIVES = ("exact", "bound", "multilook")


def with_slaves(p: Params, k_slaves: int, slaves_at_1: bool = False) -> Params:
    """Table I with K slaves: the per-UAV rate list sets the swarm's size."""
    rates = tuple(p.rate_min_bps[:1 if slaves_at_1 else k_slaves + 1])
    rates += (p.rate_min_bps[-1],) * (k_slaves + 1 - len(rates))
    size = {"num_uavs": k_slaves + 1} if hasattr(p, "num_uavs") else {}  # once Params has it
    return dataclasses.replace(p, rate_min_bps=rates, **size)


def median_time(fn, repeats: int):
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


BASELINE_SNIPPET = """
import statistics, time
from uav_insar_planner.params import default_params
from uav_insar_planner.solver import solve
p = default_params()
solve(p, solver="global")
times = []
for _ in range({repeats}):
    start = time.perf_counter()
    plan = solve(p, solver="global")
    times.append(time.perf_counter() - start)
print(statistics.median(times), plan.sigma_h_m)
"""


def baseline_time(src: str, repeats: int) -> tuple[float, float]:
    """(median seconds, sigma_h) of Table I solved by the package under `src`."""
    env = dict(os.environ, PYTHONPATH=src, PYTHONDONTWRITEBYTECODE="1")
    out = subprocess.run([sys.executable, "-c", BASELINE_SNIPPET.format(repeats=repeats)],
                         env=env, cwd=src, capture_output=True, text=True, check=True)
    t, sigma = out.stdout.split()
    return float(t), float(sigma)


def certified(res) -> str:
    return "yes" if res.feasible and not res.message and res.gap <= 1e-4 else "NO"


def k_table(base: Params, args) -> tuple[dict, dict, float]:
    """The per-K line of solve_global: {K: median seconds}, {K: (sigma_h, certified)},
    the largest gap."""
    medians, sigmas, worst_gap = {}, {}, 0.0
    print("K  UAVs   median [ms]  x K=2   x K-1    boxes   sigma_h [m]   lower [m]     gap"
          "  certified")
    for k in range(1, args.max_k + 1):
        p = with_slaves(base, k, args.slaves_at_1)
        reps = args.repeats if k <= 3 else max(3, args.repeats // 3) if k <= 5 else 1
        t, res = median_time(lambda p=p: solve_global(p, "proposed", "exact",
                                                      time_budget_s=args.budget), reps)
        medians[k] = t
        worst_gap = max(worst_gap, res.gap)
        value = res.lower_bound / (1.0 - res.gap)
        sigmas[k] = (value, certified(res))
        ratio2 = f"{t / medians[2]:6.1f}" if 2 in medians else "     -"
        ratio1 = f"{t / medians[k - 1]:6.1f}" if k - 1 in medians else "     -"
        print(f"{k}  {k + 1:4d}  {t * 1e3:12.1f}  {ratio2}  {ratio1}  {res.iterations:7d}  "
              f"{value:11.6f}  {res.lower_bound:10.6f}  {res.gap:.2e}  {certified(res)}")
    return medians, sigmas, worst_gap


def baselines_table(base: Params, args, medians: dict, sigmas: dict) -> None:
    """One paper-ao and one evolution solve per K, beside the global solver's line."""
    print("\nK  UAVs  method      time [s]  sigma_h [m]  / global  feasible  certified")
    for k in range(2, args.max_k + 1):
        p = with_slaves(base, k, args.slaves_at_1)
        sigma, cert = sigmas[k]
        print(f"{k}  {k + 1:4d}  global    {medians[k]:10.3f}  {sigma:11.6f}  {1.0:8.4f}"
              f"  yes       {cert}")
        for method in ("paper-ao", "evolution"):
            start = time.perf_counter()
            plan = solve(p, scheme="proposed", objective="exact", solver=method)
            dt = time.perf_counter() - start
            print(f"{k}  {k + 1:4d}  {method:9s} {dt:10.3f}  {plan.sigma_h_m:11.6f}  "
                  f"{plan.sigma_h_m / sigma:8.4f}  {'yes' if plan.feasible else 'NO ':3s}"
                  "       no")


def grid(base: Params, args) -> float:
    """The twelve scheme x objective solves per K; the largest gap."""
    worst_gap = 0.0
    print("\nall schemes x objectives (one solve each):")
    for k in range(1, min(args.max_k, args.grid_max_k) + 1):
        p = with_slaves(base, k, args.slaves_at_1)
        slowest, gap, infeasible = (0.0, ""), 0.0, 0
        for scheme in SCHEMES:
            for objective in OBJECTIVES:
                start = time.perf_counter()
                res = solve_global(p, scheme, objective, time_budget_s=args.budget)
                dt = time.perf_counter() - start
                slowest = max(slowest, (dt, f"{scheme}/{objective}"))
                if res.feasible:
                    gap = max(gap, res.gap)
                else:
                    infeasible += 1
        worst_gap = max(worst_gap, gap)
        print(f"  K = {k}: slowest {slowest[0] * 1e3:7.1f} ms ({slowest[1]}), largest gap "
              f"{gap:.2e}, infeasible {infeasible} of {len(SCHEMES) * len(OBJECTIVES)}")
    return worst_gap


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--max-k", type=int, default=MAX_UAVS - 1)
    ap.add_argument("--budget", type=float, default=10.0,
                    help="seconds of branch and bound per solve")
    ap.add_argument("--slaves-at-1", action="store_true", help="every slave at 1 Mbit/s")
    ap.add_argument("--baselines", action="store_true",
                    help="also paper-ao and evolution per K")
    ap.add_argument("--grid-max-k", type=int, default=5)
    ap.add_argument("--no-grid", action="store_true",
                    help="skip the scheme x objective grid per K")
    ap.add_argument("--baseline", metavar="SRC", help="time Table I with the package in SRC")
    args = ap.parse_args()
    base = default_params()
    solve(base, solver="global")  # warm up imports
    medians, sigmas, worst_gap = k_table(base, args)
    t_solve, plan = median_time(lambda: solve(base, solver="global"), 3 * args.repeats)
    print(f"\nTable I through solve (K = 2, {3 * args.repeats} runs): median "
          f"{t_solve * 1e3:.1f} ms, sigma_h {plan.sigma_h_m:.6f} m, gap "
          f"{plan.optimality_gap:.2e}")
    if args.baseline:
        t_base, sigma_base = baseline_time(args.baseline, 3 * args.repeats)
        print(f"baseline {args.baseline} (same runs): median {t_base * 1e3:.1f} ms, sigma_h "
              f"{sigma_base:.6f} m; baseline / this = {t_base / t_solve:.1f}x")
    if args.baselines:
        baselines_table(base, args, medians, sigmas)
    if not args.no_grid:
        worst_gap = max(worst_gap, grid(base, args))
    print(f"\ntargets: K = 2 median {medians[2] * 1e3:.1f} ms (solve_global), "
          f"{t_solve * 1e3:.1f} ms (solve) <= 10 ms; sigma_h {plan.sigma_h_m:.6f} m "
          "(Table I: 0.073640 m)", end="")
    if args.max_k >= 5:
        print(f"; K = 5 median {medians[5] * 1e3:.0f} ms <= 1000 ms "
              f"({medians[5] / medians[2]:.0f}x K = 2; target <= 25x)", end="")
    if args.max_k >= 9:
        print(f"; K = 9 {medians[9]:.1f} s <= 10 s and certified", end="")
    print(f"; largest gap {worst_gap:.2e} <= 1e-4")


if __name__ == "__main__":
    main()
