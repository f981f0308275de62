"""Benchmark of the certified global solver, side by side with the paper's AO.

Prints: the default scenario's median solve time (exact objective, proposed scheme) for the
global solver and, in the same run, for paper-ao, with their ratio; then both figure sweeps
(Figure 3: 16 points of h_amb_min over 0.5..2.0 m with q0_fixed = (-54, 74) m and
P_com^max = 10.1 dB; Figure 4: 21 points of rate_min_mbps[1] over 10..20 with
q0_fixed = (-41, 61) m and P_com^max = 9 dB; four schemes each, exact objective, both on the
paper's problem (P), `default_params(paper=True)`: rate_margin 0) with total
time, largest certified gap, the feasibility of each point (every plan re-checked by the
independent evaluator) and the blocking constraints of the infeasible ones. The sweeps run
through the project's sweep runner (study/sweep.py: each scheme's points in a chain, each
solve warm-started from the one before) and, side by side, as independent cold solves; each
is printed as the time per sweep point over the standalone default-scenario solve (and the
runner's time over the cold solves': what the warm starts save), and the two must agree
point for point within the certified gap. Last, once and outside the times, Figure 4 on the
field problem (the default rate margin), where C10 binds sooner: its table beside the paper's.

Side by side: a shared machine's speed drifts by tens of percent within a minute, so the
measurements are interleaved over `--rounds` rounds (each: Table I `--repeats` times, paper-ao
a few times, both sweeps through the runner and cold), and every time printed is the least
over the rounds of what was measured there (Table I and paper-ao: the median of the round's
solves), each the least disturbed, as timeit takes them.

Run: .venv/bin/python benchmarks/global_solver.py [--repeats 21] [--rounds 5] [--no-ao]
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


def times(params, solver: str, repeats: int) -> tuple[list[float], object]:
    """(seconds of each of `repeats` solves of Table I's proposed scheme, the last plan)."""
    out, plan = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        plan = solve(params, scheme="proposed", objective="exact", solver=solver)
        out.append(time.perf_counter() - start)
    return out, plan


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
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--no-ao", action="store_true", help="skip the paper-ao timing")
    args = ap.parse_args()
    p = default_params()
    paper = default_params(paper=True)
    solve(p, solver="global")  # warm up imports
    glob, ao, runs = [], [], []  # runs: per round, per figure (runner s, cold s, result)
    plan = ao_plan = None
    for _ in range(args.rounds):
        got, plan = times(p, "global", args.repeats)
        glob.append(statistics.median(got))
        if not args.no_ao:
            got, ao_plan = times(p, "paper-ao", max(3, args.repeats // 7 // args.rounds))
            ao.append(statistics.median(got))
        runs.append([sweep(name, index, values, paper.replace(**settings))
                     for name, index, values, settings in FIGURES.values()])
    t_glob = min(glob)
    print(f"default scenario, proposed, exact: global median {t_glob * 1e3:.1f} ms ({args.repeats}"
          f" runs; the least of {args.rounds} rounds' medians); sigma_h {plan.sigma_h_m:.6g} m, "
          f"lower bound {plan.lower_bound_m:.6g} m, gap {plan.optimality_gap:.2e}")
    if ao:
        t_ao = min(ao)
        print(f"  paper-ao median {t_ao * 1e3:.1f} ms (the least of {len(ao)} rounds'); sigma_h "
              f"{ao_plan.sigma_h_m:.6g} m (feasible {ao_plan.feasible}); "
              f"time ratio paper-ao / global = {t_ao / t_glob:.1f}x; sigma_h ratio "
              f"paper-ao / global = {ao_plan.sigma_h_m / plan.sigma_h_m:.3f}")
    grand, cold, worst, diff, count = 0.0, 0.0, 0.0, 0.0, 0
    for i, (title, (_, _, values, _)) in enumerate(FIGURES.items()):
        total = min(r[i][0] for r in runs)
        cold_s = min(r[i][4] for r in runs)
        _, gap, lines, dev, _ = runs[-1][i]
        grand, cold, count = grand + total, cold + cold_s, count + len(values) * len(SCHEMES)
        worst = max([worst] + [r[i][1] for r in runs])
        diff = max([diff] + [r[i][3] for r in runs])
        print(f"\n{title}: sigma_h [cm] per scheme ({', '.join(SCHEMES)}), exact objective")
        print("\n".join(lines))
        print(f"  {len(values) * len(SCHEMES)} solves in {total:.2f} s through the sweep runner "
              f"({cold_s:.2f} s as cold solves; the least of {args.rounds} rounds), largest gap "
              f"{gap:.2e}")
    print(f"\nboth sweeps: {grand:.2f} s total (target <= 5 s), largest certified gap "
          f"{worst:.2e} (target <= 1e-4); sigma_h of the sweep runner vs cold solves: largest "
          f"relative difference {diff:.1e}")
    print(f"  per sweep point / standalone Table I solve = {grand / count / t_glob:.2f} "
          f"(target <= 0.5); cold solves: {cold / count / t_glob:.2f}; the sweep runner over "
          f"the same points solved cold: {grand / cold:.2f}")
    field_figure(p)


def field_figure(field) -> None:
    """Figure 4 on the field problem (`field`'s rate margin), once, its table beside the
    paper's: the same points, C10 at (1 + rate_margin) R_min."""
    title = "Figure 4 (rate_min_mbps[1])"
    name, index, values, settings = FIGURES[title]
    _, _, lines, _, _ = sweep(name, index, values, field.replace(**settings))
    print(f"\n{title} on the field problem (rate_margin {field.rate_margin:g}, the default; "
          f"not in the times above): sigma_h [cm] per scheme ({', '.join(SCHEMES)})")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
