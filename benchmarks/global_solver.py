"""Benchmark of the certified global solver, side by side with the paper's AO.

Prints: the default scenario's median solve time (exact objective, proposed scheme) for the
global solver and, in the same run, for paper-ao, with their ratio; then both figure sweeps
(Figure 3: 16 points of h_amb_min over 0.5..2.0 m with q0_fixed = (-54, 74) m and
P_com^max = 10.1 dB; Figure 4: 21 points of rate_min_mbps[1] over 10..20 with
q0_fixed = (-41, 61) m and P_com^max = 9 dB; four schemes each, exact objective) with total
time, largest certified gap, the feasibility of each point (every plan re-checked by the
independent evaluator) and the blocking constraints of the infeasible ones. The sweeps run
through the project's sweep runner (study/sweep.py: each scheme's points in a chain, each
solve warm-started from the one before) and, side by side, as independent cold solves; each
is printed as the time per sweep point over the standalone default-scenario solve (and the
runner's time over the cold solves': what the warm starts save), and the two must agree
point for point within the certified gap.

Run: .venv/bin/python benchmarks/global_solver.py [--repeats 21] [--no-ao]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from uav_insar_planner.params import SCHEMES, default_params
from uav_insar_planner.solver import solve
from uav_insar_planner.study.executors import run_serial
from uav_insar_planner.study.sweep import run_sweep

FIGURES = {
    "Figure 3 (h_amb_min_m)": ("h_amb_min_m", None, np.linspace(0.5, 2.0, 16),
                               {"master_fixed_xz_m": [-54.0, 74.0], "p_com_max_db": 10.1}),
    "Figure 4 (rate_min_mbps[1])": ("rate_min_mbps", 1, np.linspace(10.0, 20.0, 21),
                                    {"master_fixed_xz_m": [-41.0, 61.0], "p_com_max_db": 9.0}),
}


def median_time(params, solver: str, repeats: int) -> tuple[float, object]:
    times, plan = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        plan = solve(params, scheme="proposed", objective="exact", solver=solver)
        times.append(time.perf_counter() - start)
    return statistics.median(times), plan


def cold_sweep(name: str, index: int | None, values, base) -> tuple[float, list]:
    """(seconds, plans): every point solved on its own, nothing carried between them."""
    plans, total = [], 0.0
    for value in values:
        if index is None:
            p = base.replace(**{name: float(value)})
        else:
            items = list(base.raw[name])
            items[index] = float(value)
            p = base.replace(**{name: items})
        for scheme in SCHEMES:
            start = time.perf_counter()
            plans.append(solve(p, scheme=scheme, objective="exact", solver="global"))
            total += time.perf_counter() - start
    return total, plans


def sweep(name: str, index: int | None, values, base):
    """(seconds, largest gap, table lines, largest relative sigma_h difference to the cold
    solves (inf where the feasibility or the blocking constraints differ), the cold solves'
    seconds) of the sweep through the sweep runner."""
    label = name if index is None else f"{name}[{index}]"
    start = time.perf_counter()
    rows = run_sweep(base, label, values, SCHEMES, objective="exact", solver="global",
                     run=run_serial)
    total = time.perf_counter() - start
    cold_s, plans = cold_sweep(name, index, values, base)
    lines, worst_gap, diff = [], 0.0, 0.0
    for i, value in enumerate(values):
        cells = []
        for row, plan in zip(rows[i * len(SCHEMES):(i + 1) * len(SCHEMES)],
                             plans[i * len(SCHEMES):(i + 1) * len(SCHEMES)], strict=True):
            if (row.feasible, row.blocking) != (plan.feasible,
                                                " ".join(plan.blocking_constraints)):
                diff = float("inf")  # feasibility or blocking constraints differ
            if row.feasible:
                worst_gap = max(worst_gap, row.optimality_gap)
                diff = max(diff, abs(row.sigma_h_m / plan.sigma_h_m - 1.0))
                cells.append(f"{row.sigma_h_m * 100:7.3f}")
            else:
                cells.append("  infeas(" + row.blocking.replace(" ", "+") + ")")
        lines.append(f"  {value:6.2f}  " + "  ".join(cells))
    return total, worst_gap, lines, diff, cold_s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=21)
    ap.add_argument("--no-ao", action="store_true", help="skip the paper-ao timing")
    args = ap.parse_args()
    p = default_params()
    solve(p, solver="global")  # warm up imports
    t_glob, plan = median_time(p, "global", args.repeats)
    print(f"default scenario, proposed, exact: global median {t_glob * 1e3:.1f} ms over "
          f"{args.repeats} runs; sigma_h {plan.sigma_h_m:.6g} m, lower bound "
          f"{plan.lower_bound_m:.6g} m, gap {plan.optimality_gap:.2e}")
    if not args.no_ao:
        reps = max(3, args.repeats // 7)
        t_ao, ao_plan = median_time(p, "paper-ao", reps)
        print(f"  paper-ao median {t_ao * 1e3:.1f} ms over {reps} runs; sigma_h "
              f"{ao_plan.sigma_h_m:.6g} m (feasible {ao_plan.feasible}); "
              f"time ratio paper-ao / global = {t_ao / t_glob:.1f}x; sigma_h ratio "
              f"paper-ao / global = {ao_plan.sigma_h_m / plan.sigma_h_m:.3f}")
    grand, cold, worst, diff, count = 0.0, 0.0, 0.0, 0.0, 0
    for title, (name, index, values, settings) in FIGURES.items():
        total, gap, lines, dev, cold_s = sweep(name, index, values, p.replace(**settings))
        grand, cold, count = grand + total, cold + cold_s, count + len(values) * len(SCHEMES)
        worst, diff = max(worst, gap), max(diff, dev)
        print(f"\n{title}: sigma_h [cm] per scheme ({', '.join(SCHEMES)}), exact objective")
        print("\n".join(lines))
        print(f"  {len(values) * len(SCHEMES)} solves in {total:.2f} s through the sweep runner "
              f"({cold_s:.2f} s as cold solves), largest gap {gap:.2e}")
    print(f"\nboth sweeps: {grand:.2f} s total (target <= 5 s), largest certified gap "
          f"{worst:.2e} (target <= 1e-4); sigma_h of the sweep runner vs cold solves: largest "
          f"relative difference {diff:.1e}")
    print(f"  per sweep point / standalone Table I solve = {grand / count / t_glob:.2f} "
          f"(target <= 0.5); cold solves: {cold / count / t_glob:.2f}; the sweep runner over "
          f"the same points solved cold: {grand / cold:.2f}")


if __name__ == "__main__":
    main()
