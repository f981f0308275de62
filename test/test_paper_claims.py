"""The paper's quantitative claims (section V), reproduced where they reproduce.

gain = 1 - sigma_h(proposed) / sigma_h(benchmark), over the sweep points where both are
feasible, with the certified global solver (exact objective) unless stated. Where a claim does
not reproduce, the test pins what we measure instead, and docs/science/paper.md says so
plainly.
"""
import math

import numpy as np
import pytest

from uav_insar_planner.params import default_params
from uav_insar_planner.solver import solve
from uav_insar_planner.study.sweep import gains, run_sweep

SCHEMES = ["proposed", "single-baseline", "fixed-master", "static-power"]
# on the paper's problem (P), default_params(paper=True): C10 holds R_min exactly (rate_margin
# 0), as every claim below is the paper's
FIG3 = {"master_fixed_xz_m": [-54.0, 74.0], "p_com_max_db": 10.1}
FIG4 = {"master_fixed_xz_m": [-41.0, 61.0], "p_com_max_db": 9.0}


@pytest.fixture(scope="module")
def fig3():
    p = default_params(paper=True).replace(**FIG3)
    return {obj: run_sweep(p, "h_amb_min_m", np.linspace(0.5, 2.0, 16), SCHEMES, objective=obj)
            for obj in ("exact", "bound")}


@pytest.fixture(scope="module")
def fig4():
    p = default_params(paper=True).replace(**FIG4)
    return run_sweep(p, "rate_min_mbps[1]", np.linspace(10, 20, 21), SCHEMES)


def bound_gains(rows):
    by = {(r.value, r.scheme): r for r in rows if r.feasible}
    out = {}
    for s in SCHEMES[1:]:
        g = [1 - by[(v, "proposed")].sigma_h_bound_m / r.sigma_h_bound_m
             for (v, sc), r in by.items() if sc == s and (v, "proposed") in by]
        out[s] = min(g)
    return out


def test_fig3_proposed_beats_single_baseline_by_the_dual_baseline_factor(fig3):
    """Paper: >= 49 %. Measured: 29.3 % = 1 - 1/sqrt(2) on the bound (two equal C8-tight
    baselines average the error by sqrt 2), 29.2-29.5 % on sigma_h. Not reproduced."""
    assert bound_gains(fig3["bound"])["single-baseline"] == pytest.approx(1 - 1 / math.sqrt(2),
                                                                          abs=1e-4)
    g = gains(fig3["exact"])["single-baseline"]
    assert 0.29 <= g < 0.49


def test_fig3_proposed_beats_fixed_master(fig3):
    """Paper: >= 23.6 %. Measured on sigma_h: least 18.1 % (at h_amb_min = 2 m). On the bound
    the two tie once q0_fixed allows both C8 constraints tight. Reproduced in direction only."""
    g = gains(fig3["exact"])["fixed-master"]
    assert 0.17 <= g < 0.236
    assert bound_gains(fig3["bound"])["fixed-master"] == pytest.approx(0.0, abs=1e-6)


def test_fig3_proposed_never_worse_than_static_power(fig3):
    """Paper: >= 8.2 %. Measured: 0 to 15 % on sigma_h (proposed never worse); not reproduced
    as a floor."""
    by = {(r.value, r.scheme): r for r in fig3["exact"]}
    diffs = [by[(v, "static-power")].sigma_h_m - by[(v, "proposed")].sigma_h_m
             for v in {r.value for r in fig3["exact"]}]
    assert min(diffs) >= -1e-9
    assert gains(fig3["exact"])["static-power"] < 0.082


def test_fig3_static_power_stays_feasible(fig3):
    """Paper: benchmark 3 infeasible from h_amb_min = 0.9 m. Measured: feasible at all 16
    points; a larger h_amb_min only tightens C8, which a slave near the master's line of sight
    always meets. Not reproduced."""
    assert all(r.feasible for r in fig3["exact"] if r.scheme == "static-power")
    assert all(r.feasible for r in fig3["exact"])


def test_fig4_static_power_loses_feasibility_first(fig4):
    """Paper: benchmark 3 infeasible for R_min,1 above 16.8 Mbit/s. Measured edge 17.18 Mbit/s
    (feasible at 17.0, infeasible from 17.5) while the proposed scheme stays feasible to 18.37.
    Reproduced in substance, 2 % off in the edge."""
    by = {(r.value, r.scheme): r for r in fig4}
    assert by[(17.0, "static-power")].feasible
    assert not by[(17.5, "static-power")].feasible
    assert "C10" in by[(17.5, "static-power")].blocking.split()
    assert by[(17.5, "proposed")].feasible and by[(18.0, "proposed")].feasible
    p = default_params(paper=True).replace(**FIG4)
    edge_lo = p.replace(rate_min_mbps=[10.0, 17.15, 1.0])
    edge_hi = p.replace(rate_min_mbps=[10.0, 17.22, 1.0])
    assert solve(edge_lo, scheme="static-power").feasible
    assert not solve(edge_hi, scheme="static-power").feasible


def test_fig4_proposed_best_wherever_feasible(fig4):
    """Paper: the proposed scheme outperforms all benchmarks (Figure 4). Reproduced on sigma_h:
    proposed <= every feasible benchmark at every point."""
    by = {(r.value, r.scheme): r for r in fig4}
    for (v, s), r in by.items():
        if s != "proposed" and r.feasible:
            assert by[(v, "proposed")].feasible
            assert by[(v, "proposed")].sigma_h_m <= r.sigma_h_m + 1e-9


def test_fig4_every_scheme_infeasible_above_18_4_mbps(fig4):
    """Finding: the paper plots all schemes up to 20 Mbit/s; with Table I's units every scheme
    is infeasible above 18.37 Mbit/s (U1 cannot reach the 9 dBW station disk inside its C3/C5
    wedge)."""
    for r in fig4:
        if r.value >= 18.5:
            assert not r.feasible and r.blocking
