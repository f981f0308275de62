"""h_amb_ratio, the ladder of C8 limits h_amb,k >= h_amb_min rho^(k-1), on every back end.

Five UAVs (K = 4 slaves) at rho = 1.25: the certified global plan passes the checker with every
pair on or above its rung (the rungs bind), costs sigma_h over the rho = 1 optimum, and the
AO and evolution plans are no better than its certified lower bound. rho = 1 is unchanged.
"""
from __future__ import annotations

import functools

import pytest

from uav_insar_planner import model
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import ParamError, default_params
from uav_insar_planner.solver.global_opt import branch_bound
from uav_insar_planner.solver.global_opt.optimum import solve_global
from uav_insar_planner.solver.problem import make_problem

RHO = 1.25
FIVE = {"num_uavs": 5, "rate_min_mbps": [10, 16.95, 1, 1, 1]}


@functools.cache
def five(rho: float):
    p = default_params().replace(h_amb_ratio=rho, **FIVE)
    return p, solve_global(p, "proposed", "exact")


def test_the_rung_is_h_amb_min_times_rho_to_the_slave_index_minus_one():
    p = default_params().replace(h_amb_ratio=2.0, **FIVE)
    assert [model.h_amb_min_of(p, k) for k in (1, 2, 3, 4)] == [1.2, 2.4, 4.8, 9.6]
    assert model.baseline_max(p, 100.0, 3) == pytest.approx(model.baseline_max(p, 100.0) / 4)
    assert model.master_range_min_c8(p, 2.0, 2) == pytest.approx(
        2 * model.master_range_min_c8(p, 2.0))


@pytest.mark.parametrize("value", [0.5, 10.5, float("nan")])
def test_a_ratio_outside_one_to_ten_is_refused_naming_field_and_range(value):
    with pytest.raises(ParamError, match=r"h_amb_ratio.*\[1, 10\]"):
        default_params().replace(h_amb_ratio=value)


def test_slaves_on_different_rungs_are_not_interchangeable():
    p = default_params().replace(**FIVE)
    same = branch_bound.interchangeable_pairs(make_problem(p, "proposed", "exact"))
    assert same == [(1, 2), (2, 3)]  # U2..U4 share their station disk (1 Mbit/s each)
    q = p.replace(h_amb_ratio=RHO)
    assert branch_bound.interchangeable_pairs(make_problem(q, "proposed", "exact")) == []


def test_the_global_plan_keeps_every_rung_and_is_certified():
    p, res = five(RHO)
    _, plain = five(1.0)
    assert res.feasible
    ev = evaluate(p, res.formation, res.p_com, "proposed")
    assert ev.feasible, ev.violated
    h = [ev.metrics["pairs"][f"uav{k}"]["h_amb_m"] for k in (1, 2, 3, 4)]
    rung = [model.h_amb_min_of(p, k) for k in (1, 2, 3, 4)]
    assert all(hk >= rk * (1 - 1e-6) for hk, rk in zip(h, rung, strict=True)), (h, rung)
    assert sum(abs(hk / rk - 1) <= 1e-6 for hk, rk in zip(h, rung, strict=True)) >= 2, (h, rung)
    # the plain plan breaks the ladder; the ladder costs sigma_h
    assert not evaluate(p, plain.formation, plain.p_com, "proposed").feasible
    sigma_plain = evaluate(p.replace(h_amb_ratio=1.0), plain.formation, plain.p_com,
                           "proposed").sigma_h
    assert ev.sigma_h >= sigma_plain
    assert res.gap <= 1e-4
    assert res.lower_bound <= ev.sigma_h * (1 + 1e-9)


@pytest.mark.parametrize("solver", ["paper-ao", "evolution"])
def test_no_other_back_end_beats_the_certified_lower_bound(solver):
    from uav_insar_planner.solver import solve

    p, res = five(RHO)
    plan = solve(p, solver=solver)
    ev = evaluate(p, plan.formation, plan.p_com_w, "proposed")
    assert ev.feasible, (solver, ev.violated)
    assert ev.sigma_h >= res.lower_bound * (1 - 1e-6)


def test_ratio_one_is_table_one():
    p = default_params()
    assert p.h_amb_ratio == 1.0
    res = solve_global(p, "proposed", "exact")
    assert evaluate(p, res.formation, res.p_com, "proposed").sigma_h == pytest.approx(
        0.073640, abs=5e-7)
