"""The exact multilook phase statistics (multilook.py) against closed forms, the Cramer-Rao
figure and the Monte-Carlo, and the planner objective built on them."""
import math

import numpy as np
import pytest
from scipy.special import spence

from uav_insar_planner import model, multilook
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.montecarlo import multilook_phase, std_ci
from uav_insar_planner.params import MULTILOOK_MAX_LOOKS, ParamError, default_params
from uav_insar_planner.solver import solve


def single_look_std(gamma) -> np.ndarray:
    """Closed form for n_L = 1: sigma^2 = pi^2/3 - pi arcsin(g) + arcsin(g)^2 - Li2(g^2)/2
    (Li2 the dilogarithm, scipy's spence(1 - g^2)), the oracle of the integration."""
    g = np.asarray(gamma, dtype=float)
    a = np.arcsin(g)
    return np.sqrt(math.pi**2 / 3.0 - math.pi * a + a * a - 0.5 * spence(1.0 - g * g))


def test_single_look_integral_matches_the_closed_form_and_has_unit_mass():
    g = np.array([0.0, 0.05, 0.3, 0.5441, 0.8, 0.95, 0.999])
    np.testing.assert_allclose(multilook.phase_std_exact(g, 1), single_look_std(g),
                               rtol=1e-9)
    for looks in (1, 4, 64):
        mass, _ = multilook.phase_moments(g, looks)
        np.testing.assert_allclose(mass, 1.0, atol=1e-9)
    assert multilook.phase_std_exact(0.0, 4) == pytest.approx(multilook.UNIFORM_STD, rel=1e-9)


@pytest.mark.parametrize("looks", [1, 4, 32])
def test_table_is_accurate_and_strictly_decreasing_in_coherence(looks):
    g = np.random.default_rng(looks).uniform(0.01, 0.999, 300)
    np.testing.assert_allclose(multilook.phase_std(g, looks),
                               multilook.phase_std_exact(g, looks),
                               rtol=multilook.TABLE_REL_ERROR)
    v, log_s = multilook._table(looks)
    slope = np.diff(log_s) / np.diff(v)
    # sigma decreases in gamma, and the slope < 1 keeps the solver's bounds valid
    assert slope.min() > 0.0 and slope.max() < 0.7
    fine = np.linspace(0.0, 1.0, 20001)
    assert np.all(np.diff(multilook.phase_std(fine, looks)) < 0.0)


def test_exact_std_tends_to_cramer_rao_at_high_coherence_and_many_looks():
    ratios = [multilook.phase_std_exact(g, n) / model.phase_error_crb(g, n)
              for g, n in ((0.98, 64), (0.95, 256), (0.99, 1000))]
    assert 1.0 < ratios[2] < ratios[1] < ratios[0] < 1.01
    # ... and is far above it at Table I's coherence and 4 looks (the 0.750 vs 0.545)
    assert multilook.phase_std(0.5441, 4) == pytest.approx(0.7488, abs=5e-4)
    assert model.phase_error_crb(0.5441, 4) == pytest.approx(0.5452, abs=5e-4)


@pytest.mark.parametrize("gamma,looks", [(0.5441, 4), (0.3, 1), (0.8, 2), (0.6, 16),
                                         (0.9, 8)])
def test_exact_std_is_inside_the_monte_carlo_interval(gamma, looks):
    psi = multilook_phase(np.random.default_rng(7), gamma, looks, 100_000)
    est = std_ci(psi)
    assert est.lo <= multilook.phase_std_exact(gamma, looks) <= est.hi
    assert est.hi - est.lo < 0.02 * est.value


def test_multilook_objective_plans_pass_the_checker_with_a_certificate():
    p = default_params()
    for scheme in ("proposed", "single-baseline", "fixed-master"):
        plan = solve(p, scheme=scheme, objective="multilook")
        assert plan.feasible and plan.objective == "multilook"
        ev = evaluate(p, plan.formation, plan.p_com_w, scheme)
        assert ev.feasible and "all closed" in plan.certificate
        value = plan.metrics["multilook"]["sigma_h_m"]  # recomputed from the checker's pairs
        assert plan.lower_bound_m <= value <= plan.lower_bound_m * (1 + 1e-4)
        assert 0.0 <= plan.optimality_gap <= 1e-4
        # the real error exceeds the Cramer-Rao figure at these coherences
        assert value > 1.3 * plan.sigma_h_m
        # no formation the exact objective finds is better under the multilook objective
        other = solve(p, scheme=scheme, objective="exact")
        from uav_insar_planner.multilook import plan_metrics

        assert plan_metrics(other.metrics["pairs"], p.looks)["sigma_h_m"] >= value * (1 - 1e-4)


def test_paper_ao_and_too_many_looks_refuse_multilook_in_one_line():
    p = default_params()
    with pytest.raises(ParamError) as err:
        solve(p, objective="multilook", solver="paper-ao")
    assert len(err.value.problems) == 1 and "paper-ao" in str(err.value)
    with pytest.raises(ParamError) as err:  # for every objective: looks stops there
        p.replace(objective="multilook", looks=MULTILOOK_MAX_LOOKS + 1)
    assert len(err.value.problems) == 1
    assert err.value.problems[0].startswith(f"looks: value {MULTILOOK_MAX_LOOKS + 1} is not "
                                            "allowed; expected an integer in "
                                            f"[1, {MULTILOOK_MAX_LOOKS}]")


def test_no_feasible_formation_near_the_optimum_beats_the_certified_lower_bound():
    from uav_insar_planner.multilook import plan_metrics
    from uav_insar_planner.solver.power import schedules

    p = default_params()
    plan = solve(p, objective="multilook")
    rng = np.random.default_rng(2)
    feasible = 0
    for scale in (0.05, 0.5, 2.0):
        for _ in range(250):
            q = plan.formation + rng.normal(0.0, scale, (3, 2))
            q[0, 0] = model.master_x(q[0, 1], p.x_t, p.theta0)  # C2
            ev = evaluate(p, q, schedules(p, q, "proposed"), "proposed")
            if ev.feasible:
                feasible += 1
                value = plan_metrics(ev.metrics["pairs"], p.looks)["sigma_h_m"]
                assert value >= plan.lower_bound_m
    assert feasible >= 30


@pytest.mark.parametrize("looks", [1, 4, 64])
def test_multilook_weight_increases_with_slave_range(looks):
    # the property the exact inner solve and the box bounds rely on (slave_ranges.py)
    from uav_insar_planner.solver.global_opt.kernel import slave_weight
    from uav_insar_planner.solver.problem import make_problem

    p = default_params().replace(looks=looks, coherence_other=0.3)
    sc = make_problem(p, "proposed", "multilook")
    r = np.linspace(1.0, 2000.0, 4000)
    for r0 in (20.0, 60.0, 130.0):
        for t in (0.3, 0.66, 0.79, 0.84):
            w = slave_weight(sc, r0, t, r)
            assert np.all(np.diff(w) > 0)
