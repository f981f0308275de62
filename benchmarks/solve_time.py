"""Wall time of the default solve per scheme, and of a 16-point h_amb_min sweep (0.5..2.0 m).

paper-ao always; the global solver (solver/global_opt/) side by side when it is importable and
solves, with the ratio global / paper-ao of the medians. Not a test: prints a table.

Run: .venv/bin/python benchmarks/solve_time.py [--runs 5]
"""
from __future__ import annotations

import argparse
import importlib.util
import statistics
import time
from collections.abc import Callable

import numpy as np

from uav_insar_planner.params import default_params
from uav_insar_planner.solver import solve

SCHEMES = ("proposed", "single-baseline", "fixed-master", "static-power")


def timed(fn: Callable[[], object], runs: int) -> tuple[float, float, float]:
    """(median, min, max) wall seconds of `runs` calls, after one untimed warm-up call."""
    fn()
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), min(times), max(times)


def global_available() -> str:
    """'' when the global back end can solve the default scenario, else why not."""
    if importlib.util.find_spec("uav_insar_planner.solver.global_opt") is None:
        return "solver/global_opt/ not present"
    try:
        plan = solve(default_params(), scheme="proposed", solver="global")
    except Exception as exc:  # noqa: BLE001 - report any failure of the other back end
        return f"global solver failed: {type(exc).__name__}: {exc}"
    return "" if plan.feasible else "global solver returned infeasible at the defaults"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    p = default_params()
    why_not = global_available()
    solvers = ["paper-ao"] + ([] if why_not else ["global"])

    def sweep(scheme: str, solver: str) -> Callable[[], object]:
        return lambda: [solve(p.replace(h_amb_min_m=float(h)), scheme=scheme, solver=solver)
                        for h in np.linspace(0.5, 2.0, 16)]

    cases = [(f"default {s}", lambda s=s, v=v: solve(p, scheme=s, solver=v), v)
             for s in SCHEMES for v in solvers]
    sweep_runs = max(1, args.runs // 2)
    rows = []
    for name, fn, solver in cases:
        rows.append((name, solver, args.runs, *timed(fn, args.runs)))
    for solver in solvers:
        rows.append(("h_amb_min sweep 16 pts proposed", solver, sweep_runs,
                     *timed(sweep("proposed", solver), sweep_runs)))
    print(f"{'case':34} {'solver':9} {'runs':>4} {'median s':>9} {'min s':>8} {'max s':>8}"
          f" {'global/ao':>9}")
    medians = {(r[0], r[1]): r[3] for r in rows}
    for name, solver, runs, med, lo, hi in rows:
        ratio = ""
        if solver == "global":
            ratio = f"{med / medians[(name, 'paper-ao')]:9.2f}"
        print(f"{name:34} {solver:9} {runs:4d} {med:9.3f} {lo:8.3f} {hi:8.3f} {ratio:>9}")
    if why_not:
        print(f"(global solver not timed: {why_not})")


if __name__ == "__main__":
    main()
