"""The three back ends side by side over the swarm's size: global, paper-ao and evolution.

For K = 2..5 slaves (num_uavs 3..6, rates [10, 16.95] + [1] * (K - 1) Mbit/s) and a set of
scenarios (Table I, h_amb_min 0.8 and 1.6 m, d_min 3 m, Table I's fixed master), each method
solves the exact objective. Per K and method the table gives: how many scenarios it solved to
a plan the independent checker accepts (feasibility rate), its sigma_h against the best plan of
that scenario (the certified global optimum when the global solver handles K slaves, else the
best of the methods that ran: then not certified), as the median and the worst ratio, and the
median solve time. Whether the global solver handles K slaves is found out by trying (it raises
for K it does not search), so the script runs before and after the K-slave search lands.

Run: .venv/bin/python benchmarks/baselines.py [--repeats 1]
"""
from __future__ import annotations

import argparse
import statistics
import time

from uav_insar_planner.params import default_params
from uav_insar_planner.solver import SolverFailure, solve
from uav_insar_planner.swarm import MIN_UAVS

SLAVE_COUNTS = (2, 3, 4, 5)
METHODS = ("global", "paper-ao", "evolution")
BASE_RATES_MBPS = [10.0, 16.95]  # Table I's U0 and U1; every further slave 1 Mbit/s
SCENARIOS = {
    "Table I": ({}, "proposed"),
    "h_amb_min 0.8 m": ({"h_amb_min_m": 0.8}, "proposed"),
    "h_amb_min 1.6 m": ({"h_amb_min_m": 1.6}, "proposed"),
    "d_min 3 m": ({"d_min_m": 3.0}, "proposed"),
    "fixed master": ({}, "fixed-master"),
}


def params_for(slaves: int, overrides: dict):
    rates = BASE_RATES_MBPS + [1.0] * (slaves + 1 - len(BASE_RATES_MBPS))
    return default_params().replace(num_uavs=slaves + 1, rate_min_mbps=rates, **overrides)


def run(p, scheme: str, method: str, repeats: int):
    """(plan, median seconds), or (None, reason) when the back end does not handle it."""
    times, plan = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        try:
            plan = solve(p, scheme, "exact", method)
        except SolverFailure as exc:
            # the back end's own words, without solve()'s "a bug: please report" tail
            return None, str(exc).split(": ", 2)[-1].split(" (a bug")[0]
        times.append(time.perf_counter() - start)
    return plan, statistics.median(times)


def table_rows(slaves: int, repeats: int) -> list[str]:
    """One Markdown row per method for K = `slaves`."""
    results = {m: {} for m in METHODS}
    notes: dict[str, str] = {}
    for name, (overrides, scheme) in SCENARIOS.items():
        p = params_for(slaves, overrides)
        for method in METHODS:
            plan, t = run(p, scheme, method, repeats)
            if plan is None:
                notes[method] = f"skipped: {t}"
                continue
            results[method][name] = (plan, t)
    certified = "global" not in notes
    rows = []
    for method in METHODS:
        if method in notes:
            rows.append(f"| {slaves} | {method} | - | - | - | - | {notes[method]} |")
            continue
        ratios, times, ok = [], [], 0
        for name, (plan, t) in results[method].items():
            times.append(t)
            feasible = [r[name][0].sigma_h_m for r in results.values()
                        if name in r and r[name][0].feasible]
            if not plan.feasible:
                continue
            ok += 1
            best = (results["global"][name][0].sigma_h_m if certified
                    and results["global"][name][0].feasible else min(feasible))
            ratios.append(plan.sigma_h_m / best)
        ref = "certified optimum" if certified else "best of the methods run"
        mid, worst = ((f"{statistics.median(ratios):.4f}", f"{max(ratios):.4f}") if ratios
                      else ("-", "-"))
        rows.append(f"| {slaves} | {method} | {ok}/{len(results[method])} | {mid} | {worst} | "
                    f"{1e3 * statistics.median(times):.0f} ms | against the {ref} |")
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=1, help="solves per point for the time")
    args = ap.parse_args()
    print(f"exact objective; scenarios: {', '.join(SCENARIOS)}; num_uavs = K + "
          f"{MIN_UAVS - 1}\n")
    print("| K | method | feasible | sigma_h / best, median | worst | median time | note |")
    print("|---|---|---|---|---|---|---|")
    for slaves in SLAVE_COUNTS:
        for row in table_rows(slaves, args.repeats):
            print(row, flush=True)


if __name__ == "__main__":
    main()
