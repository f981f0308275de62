"""The paper-faithful AO solver (solver="paper-ao") and its benchmark schemes."""
from __future__ import annotations

import math

import numpy as np
import pytest

from uav_insar_planner import model
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.model import slave_range_max
from uav_insar_planner.params import default_params
from uav_insar_planner.schemes import static_power_w
from uav_insar_planner.solver import solve
from uav_insar_planner.solver.ao.closed_forms import c7_slopes, master_range_max
from uav_insar_planner.solver.power import schedules
from uav_insar_planner.solver.start_grid import find_start

SCHEMES = ("proposed", "single-baseline", "fixed-master", "static-power")


@pytest.fixture(scope="module")
def plans():
    p = default_params()
    return {s: solve(p, scheme=s, objective="bound", solver="paper-ao") for s in SCHEMES}


@pytest.mark.parametrize("scheme", SCHEMES)
def test_default_plan_is_feasible_by_the_checker(plans, scheme):
    plan = plans[scheme]
    assert plan.feasible, plan.message
    ev = evaluate(default_params(), plan.formation, plan.p_com_w, scheme)
    assert ev.feasible, ev.violated
    assert plan.iterations >= 1


@pytest.mark.parametrize("scheme", SCHEMES[1:])
def test_proposed_bound_not_above_benchmarks(plans, scheme):
    assert plans["proposed"].sigma_h_bound_m <= plans[scheme].sigma_h_bound_m * (1 + 1e-6)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_bound_is_above_sigma_h(plans, scheme):
    assert plans[scheme].sigma_h_bound_m >= plans[scheme].sigma_h_m


def test_scheme_shapes(plans):
    p = default_params()
    single = plans["single-baseline"]
    assert np.isnan(single.formation[2]).all() and not single.p_com_w[2].any()
    assert np.allclose(plans["static-power"].p_com_w, static_power_w(p))
    assert np.array_equal(plans["fixed-master"].formation[0], np.array(p.master_fixed))


def test_deterministic():
    p = default_params()
    a, b = (solve(p, scheme="proposed", solver="paper-ao") for _ in range(2))
    assert np.array_equal(a.formation, b.formation)
    assert np.array_equal(a.p_com_w, b.p_com_w)
    assert a.iterations == b.iterations
    # the default objective is "exact": paper-ao still runs the paper's bound and says so
    assert "objective 'exact' requested" in a.message


@pytest.mark.parametrize("scheme", SCHEMES)
def test_start_is_feasible(scheme):
    p = default_params()
    start = find_start(p, scheme).formation
    ev = evaluate(p, start, schedules(p, start, scheme), scheme)
    assert ev.feasible, ev.violated


@pytest.mark.parametrize(("override", "scheme", "expected"), [
    ({"z_max_m": 30.0}, "proposed", {"C1", "C5"}),            # swath needs z_0 >= 47 m
    ({"swath_min_m": 500.0}, "single-baseline", {"C1", "C5"}),
    ({"master_fixed_xz_m": [-50.0, 74.0]}, "fixed-master", {"C2"}),
    ({"rate_min_mbps": [10.0, 40.0, 1.0]}, "proposed", {"C10"}),
])
def test_infeasible_reports_blocking_families(override, scheme, expected):
    plan = solve(default_params().replace(**override), scheme=scheme, solver="paper-ao")
    assert not plan.feasible
    assert expected <= set(plan.blocking_constraints), plan.message


@pytest.mark.parametrize("gamma_rg_min", [0.8, 0.95, 0.99])
def test_proposition2_equivalence(gamma_rg_min):
    """C7 (eq. 10 with X of eq. 11) holds iff C7a (theta <= theta_0) / C7b (theta > theta_0)."""
    p = default_params().replace(coherence_rg_min=gamma_rg_min)
    alpha_a, alpha_b = c7_slopes(p)
    bp = p.fractional_bandwidth
    for theta in np.radians(np.linspace(0.5, 89.5, 1781)):
        g = float(model.coherence_baseline(model.chi(p.theta0, theta), bp))
        if abs(g - gamma_rg_min) < 1e-9:
            continue
        if theta <= p.theta0:
            prop2 = alpha_a is None or math.tan(theta) >= alpha_a
        else:
            prop2 = alpha_b is None or math.tan(theta) <= alpha_b
        assert (g >= gamma_rg_min) == prop2, math.degrees(theta)


def c4_surrogate(q: np.ndarray, q_ref: np.ndarray, q_other: np.ndarray) -> float:
    """Eq. (18) as a number: 2 q^T (q_ref - q_other) - ||q_ref||^2 + ||q_other||^2, the form
    the AO sub-problems' C4~ constraints (ao/master.py, ao/slave.py) hold >= d_min^2 (the paper
    prints d_min; a bound on the squared distance needs the squared threshold)."""
    return float(2.0 * q @ (q_ref - q_other) - q_ref @ q_ref + q_other @ q_other)


def test_c4_surrogate_is_a_lower_bound():
    """Eq. (18) is the tangent plane of ||q - q_other||^2 at q_ref: below it everywhere, equal
    at q_ref, so surrogate >= d_min^2 implies C4."""
    rng = np.random.default_rng(0)
    for _ in range(2000):
        q, q_ref, q_other = rng.uniform(-100, 100, size=(3, 2))
        sur = c4_surrogate(q, q_ref, q_other)
        exact = float(np.sum((q - q_other) ** 2))
        assert sur <= exact + 1e-9 * max(1.0, exact)
        assert math.isclose(c4_surrogate(q_ref, q_ref, q_other),
                            float(np.sum((q_ref - q_other) ** 2)), rel_tol=1e-12, abs_tol=1e-9)


def test_c6_range_limits_are_tight():
    p = default_params()
    gm = model.gamma_m(p)
    r0 = 70.0
    rk = slave_range_max(p, r0)
    g = float(model.coherence_snr(model.snr_monostatic(r0, gm), model.snr_bistatic(r0, rk, gm)))
    assert math.isclose(g, p.coherence_snr_min, rel_tol=1e-9)
    r0_max = master_range_max(p, [rk])
    assert math.isclose(r0_max, r0, rel_tol=1e-7)


def test_the_h_amb_ratio_is_a_per_slave_c8_the_checker_accepts():
    from uav_insar_planner.solver.ao.algorithm2 import solve_ao

    p = default_params().replace(num_uavs=4, rate_min_mbps=[10, 16.95, 1, 1])
    plain, ladder = (solve_ao(p.replace(h_amb_ratio=rho), "proposed", "exact")
                     for rho in (1.0, 1.5))
    q = p.replace(h_amb_ratio=1.5)
    ev = evaluate(q, ladder.formation, ladder.p_com, "proposed")
    assert ladder.feasible and ev.feasible, ev.violated
    h = [ev.metrics["pairs"][f"uav{k}"]["h_amb_m"] for k in (1, 2, 3)]
    assert h == pytest.approx([1.2, 1.8, 2.7], rel=1e-5)  # every rung binds
    assert ev.sigma_h > evaluate(p, plain.formation, plain.p_com, "proposed").sigma_h
    # the plain plan's equal h_amb break the ladder's upper rungs
    assert evaluate(q, plain.formation, plain.p_com, "proposed").violated == ["C8"]
