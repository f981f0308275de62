"""What diverse heights of ambiguity cost in sigma_h and gain in ambiguity rate.

At Table I every slave's C8 binds, so every pair has h_amb = h_amb^min and the pairs cannot
resolve each other's ambiguities (montecarlo.resolve_ambiguities can only align them). The
scenario parameter h_amb_ratio = rho asks for a ladder h_amb,k >= h_amb^min rho^(k-1), k = 1..K
(model.h_amb_min_of), which shortens every baseline but the first and so raises
the planned sigma_h; the Monte-Carlo then measures the ambiguity rate without and with
resolution across the K pairs. rho = 1 is (P) itself.

Prints one Markdown table: K, rho, the pairs' h_amb, sigma_h of the model (Cramer-Rao, the
checker's), the exact multilook fused sigma_h, and from the Monte-Carlo: the fused ambiguity
rate without / with resolution and the rms height error with the ambiguities included, without /
with resolution. Every plan passes the independent checker (evaluate) or is reported.

Run: .venv/bin/python benchmarks/ambiguity_diversity.py [--samples 100000] [--seed 0]
[--solver global|paper-ao|evolution] (default global, the certified optimum)
"""
from __future__ import annotations

import argparse

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.montecarlo import pairs_of_formation, simulate
from uav_insar_planner.param_specs.science import SOLVERS
from uav_insar_planner.params import Params, default_params
from uav_insar_planner.solver import solve
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS

RATIOS = (1.0, 1.1, 1.25, 1.5, 2.0)
SLAVE_COUNTS = (2, 4)
# Table I's rates for U0 and U1, 1 Mbit/s for every further slave (as Table I's U2)
BASE_RATES_MBPS = (10.0, 16.95)
EXTRA_RATE_MBPS = 1.0


def params_for(slaves: int, ratio: float, solver: str) -> Params:
    """Table I with `slaves` slaves and the C8 ladder h_amb_ratio = `ratio`."""
    rates = list(BASE_RATES_MBPS) + [EXTRA_RATE_MBPS] * (slaves + 1 - len(BASE_RATES_MBPS))
    return default_params().replace(num_uavs=slaves + 1, rate_min_mbps=rates, solver=solver,
                                    h_amb_ratio=ratio)


def row(slaves: int, ratio: float, samples: int, seed: int, solver: str) -> str:
    p = params_for(slaves, ratio, solver)
    result = solve(p)
    ev = evaluate(p, result.formation, result.p_com_w, "proposed") if result.feasible else None
    if ev is None or not ev.feasible:
        why = ", ".join(ev.violated) if ev else ", ".join(result.blocking_constraints)
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
    ap.add_argument("--solver", choices=SOLVERS, default="global")
    args = ap.parse_args()
    print(f"Table I (num_uavs {DEFAULT_NUM_UAVS} is K = {DEFAULT_NUM_UAVS - 1}), {args.solver}, "
          f"proposed; Monte-Carlo {args.samples} samples per pair, seed {args.seed}\n")
    print("| K | rho | h_amb,k m | sigma_h model m | sigma_h exact m | ambiguity % without / "
          "resolved | sigma_h with ambiguities m, without / resolved |")
    print("|---|---|---|---|---|---|---|")
    for slaves in SLAVE_COUNTS:
        for ratio in RATIOS:
            print(row(slaves, ratio, args.samples, args.seed, args.solver), flush=True)


if __name__ == "__main__":
    main()
