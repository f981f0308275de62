"""The certified global solver under a time budget, and swarms of up to ten UAVs.

A search stopped by its budget must still hand back a feasible plan (as the independent
checker sees it) with a proven lower bound, and say that the certificate is incomplete: never
a silent uncertified answer.
"""
from __future__ import annotations

import math

import pytest

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import default_params
from uav_insar_planner.solver.global_opt.optimum import solve_global
from uav_insar_planner.swarm import MAX_UAVS


def swarm(num_uavs: int):
    """Table I with `num_uavs` UAVs, every slave at 1 Mbit/s (the master keeps 10)."""
    return default_params().replace(num_uavs=num_uavs,
                                    rate_min_mbps=[10.0] + [1.0] * (num_uavs - 1))


def test_ten_uavs_are_a_swarm():
    assert MAX_UAVS == 10
    assert swarm(10).num_uavs == 10


@pytest.mark.parametrize("budget_s", [0.0, 0.5])
def test_budget_reached_returns_the_best_feasible_plan_and_its_gap(budget_s):
    p = swarm(10)
    res = solve_global(p, "proposed", "exact", time_budget_s=budget_s)
    ev = evaluate(p, res.formation, res.p_com, "proposed")
    assert res.feasible and ev.feasible, ev.violated
    assert "certificate incomplete: time budget reached" in res.message
    assert "time budget reached" in res.certificate
    assert f"{res.gap:.2g}" in res.message
    # The gap is the proven one: the bound is below the plan's own (independent) sigma_h.
    assert 0.0 < res.gap < 0.05
    assert res.lower_bound <= ev.sigma_h * (1.0 + 1e-9)
    assert math.isclose(res.gap, (ev.sigma_h - res.lower_bound) / ev.sigma_h, rel_tol=1e-6)


def test_a_budget_the_search_does_not_need_changes_nothing():
    p = swarm(3)
    free = solve_global(p, "proposed", "exact")
    timed = solve_global(p, "proposed", "exact", time_budget_s=60.0)
    assert free.message == timed.message == ""
    assert timed.gap <= 1e-4
    assert (timed.formation == free.formation).all()
