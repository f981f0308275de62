"""What diverse heights of ambiguity cost in sigma_h and gain in ambiguity rate.

At Table I every slave's C8 binds, so every pair has h_amb = h_amb^min and the pairs cannot
resolve each other's ambiguities (montecarlo.resolve_ambiguities can only align them). The
option tried here asks the AO for a ladder h_amb,k >= h_amb^min rho^(k-1), k = 1..K
(solver/ao/closed_forms.c8_ladder), which shortens every baseline but the first and so raises
the planned sigma_h; the Monte-Carlo then measures the ambiguity rate without and with
resolution across the K pairs. rho = 1 is (P) itself.

Prints one Markdown table: K, rho, the pairs' h_amb, sigma_h of the model (Cramer-Rao, the
checker's), the exact multilook fused sigma_h, and from the Monte-Carlo: the fused ambiguity
rate without / with resolution and the rms height error with the ambiguities included, without /
with resolution. Every plan passes the independent checker (evaluate) or is reported.

Run: .venv/bin/python benchmarks/ambiguity_diversity.py [--samples 100000] [--seed 0]
"""
from __future__ import annotations

import argparse

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.montecarlo import pairs_of_formation, simulate
from uav_insar_planner.params import default_params
from uav_insar_planner.solver.ao.algorithm2 import solve_ao
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS

RATIOS = (1.0, 1.1, 1.25, 1.5, 2.0)
SLAVE_COUNTS = (2, 4)
# Table I's rates for U0 and U1, 1 Mbit/s for every further slave (as Table I's U2)
BASE_RATES_MBPS = (10.0, 16.95)
EXTRA_RATE_MBPS = 1.0


def params_for(slaves: int):
    """Table I with `slaves` slaves (the AO: until the global solver searches K slaves)."""
    rates = list(BASE_RATES_MBPS) + [EXTRA_RATE_MBPS] * (slaves + 1 - len(BASE_RATES_MBPS))
    return default_params().replace(num_uavs=slaves + 1, rate_min_mbps=rates, solver="paper-ao")


def row(slaves: int, ratio: float, samples: int, seed: int) -> str:
    p = params_for(slaves)
    result = solve_ao(p, "proposed", "exact", ratio)
    ev = evaluate(p, result.formation, result.p_com, "proposed") if result.feasible else None
    if ev is None or not ev.feasible:
        why = ", ".join(ev.violated) if ev else ", ".join(result.blocking)
        return f"| {slaves} | {ratio:g} | infeasible ({why}) | | | | |"
    mc = simulate(pairs_of_formation(p, result.formation), p.looks, samples, seed)
    f = mc["fused"]
    h_amb = ", ".join(f"{v['h_amb_m']:.3f}" for v in mc["pairs"].values())
    pct = lambda e: f"{100 * e['value']:.2f}"  # noqa: E731
    return (f"| {slaves} | {ratio:g} | {h_amb} | {ev.sigma_h:.5f} | {f['sigma_h_exact_m']:.5f} | "
            f"{pct(f['ambiguity_rate'])} / {pct(f['ambiguity_rate_resolved'])} | "
            f"{f['sigma_h_with_ambiguities_m']['value']:.4f} / "
            f"{f['sigma_h_resolved_m']['value']:.4f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=100_000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(f"Table I (num_uavs {DEFAULT_NUM_UAVS} is K = {DEFAULT_NUM_UAVS - 1}), paper-ao, "
          f"proposed; Monte-Carlo {args.samples} samples per pair, seed {args.seed}\n")
    print("| K | rho | h_amb,k m | sigma_h model m | sigma_h exact m | ambiguity % without / "
          "resolved | sigma_h with ambiguities m, without / resolved |")
    print("|---|---|---|---|---|---|---|")
    for slaves in SLAVE_COUNTS:
        for ratio in RATIOS:
            print(row(slaves, ratio, args.samples, args.seed), flush=True)


if __name__ == "__main__":
    main()
