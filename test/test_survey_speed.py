"""survey/speed.py at Table I: the fastest speed for a sigma_h target, certified by the refutation
of 1.05 x it; the slowest speed a caller's `fits` allows; the certified accuracy-speed front."""
from __future__ import annotations

from itertools import pairwise

import pytest

from uav_insar_planner.params_file import load_params
from uav_insar_planner.solver import solve
from uav_insar_planner.survey.speed import (
    EVIDENCE_FACTOR,
    SpeedSearchError,
    fastest_speed,
    slowest_fitting_speed,
    speed_front,
)

TOL = 0.05  # m/s: coarse, few solves


@pytest.fixture(scope="module")
def table1():
    return load_params()


def test_the_fastest_speed_meets_the_target_and_1_05_x_it_is_refuted(table1):
    target = 0.070  # met at 2 m/s (0.0696 m), not at 2.3 m/s (0.0702 m)
    choice = fastest_speed(table1, target, 20.0, tol=TOL)
    assert choice.plan.feasible and choice.plan.sigma_h_m <= target
    assert 2.0 < choice.speed_mps < 2.3
    ev = choice.above
    assert ev.speed_mps == pytest.approx(EVIDENCE_FACTOR * choice.speed_mps)
    assert ev.feasible and ev.lower_bound_m > target  # the accuracy, not feasibility, binds
    # the evidence is what a fresh, cold solve says at that speed
    again = solve(table1.replace(speed_mps=ev.speed_mps))
    assert again.lower_bound_m > target
    assert "the accuracy bounds it" in choice.why and "\n" not in choice.why


def test_a_loose_target_is_bounded_by_feasibility_c9_c10(table1):
    choice = fastest_speed(table1, 0.09, 10.0, tol=TOL)
    assert choice.plan.feasible and choice.plan.sigma_h_m <= 0.09
    assert 4.6 < choice.speed_mps < 4.76  # (P) is infeasible past 4.7594 m/s
    assert not choice.above.feasible and choice.above.lower_bound_m == float("inf")
    assert {"C9", "C10"} <= set(choice.above.blocking)
    assert "feasibility bounds it" in choice.why


def test_a_target_met_at_v_max_returns_v_max(table1):
    choice = fastest_speed(table1, 0.08, 4.5)
    assert choice.speed_mps == 4.5 and choice.above is None and choice.solves == 1
    assert choice.plan.sigma_h_m <= 0.08 and "airframe" in choice.why


def test_an_unreachable_target_is_one_line_naming_sigma_h_max(table1):
    with pytest.raises(SpeedSearchError) as err:
        fastest_speed(table1, 0.06, 10.0, tol=TOL)  # 0.0651 m at the 0.01 m/s floor
    text = str(err.value)
    assert text.startswith("sigma_h_max_m: value 0.06") and "\n" not in text
    assert "allowed: >= 0.0651" in text


@pytest.mark.parametrize("v_max, tol, field", [(0.01, TOL, "v_max_mps"),
                                               (2000.0, TOL, "v_max_mps"),
                                               (5.0, 0.0, "tol")])
def test_an_empty_or_invalid_range_is_one_line(table1, v_max, tol, field):
    with pytest.raises(SpeedSearchError) as err:
        fastest_speed(table1, 0.07, v_max, tol=tol)
    assert str(err.value).startswith(f"{field}: value ") and "\n" not in str(err.value)


def test_an_uncertified_solver_is_refused(table1):
    with pytest.raises(SpeedSearchError, match=r"^solver: value 'evolution' is not allowed"):
        fastest_speed(table1.replace(solver="evolution"), 0.07, 5.0)


def test_slowest_fitting_speed_finds_the_step_of_fits(table1):
    calls = []

    def fits(v: float) -> bool:
        calls.append(v)
        return v >= 3.0

    choice = slowest_fitting_speed(table1, fits, 10.0, tol=TOL)
    assert 3.0 <= choice.speed_mps <= 3.0 + TOL and fits(choice.speed_mps)
    assert choice.plan.feasible and len(calls) < 20
    # going 5 % faster is certified no better
    assert choice.above.lower_bound_m >= choice.plan.sigma_h_m


def test_slowest_fitting_speed_refuses_a_survey_that_never_fits_or_is_infeasible(table1):
    with pytest.raises(SpeedSearchError, match=r"^v_max_mps: value 10 is not allowed"):
        slowest_fitting_speed(table1, lambda v: False, 10.0, tol=TOL)
    with pytest.raises(SpeedSearchError, match=r"^fits: the slowest speed that fits, 6"):
        slowest_fitting_speed(table1, lambda v: v >= 6.0, 10.0, tol=TOL)


def test_the_front_is_certified_and_rises_with_speed(table1):
    front = speed_front(table1, [0.5, 1.0, 2.0, 3.0, 4.0, 4.5, 5.0])
    feasible = [p for p in front if p.feasible]
    assert [p.speed_mps for p in feasible] == [0.5, 1.0, 2.0, 3.0, 4.0, 4.5]
    assert all(p.optimality_gap < 1e-3 and p.lower_bound_m <= p.sigma_h_m for p in feasible)
    # increasing, certified: each point's lower bound is above the previous point's sigma_h
    assert all(b.lower_bound_m > a.sigma_h_m for a, b in pairwise(feasible))
    assert front[-1].lower_bound_m == float("inf") and {"C9", "C10"} <= set(front[-1].blocking)


def test_the_warm_front_certifies_what_the_cold_one_does(table1):
    speeds = [4.0, 3.0, 4.6]
    warm, cold = speed_front(table1, speeds), speed_front(table1, speeds, warm=False)
    for w, c in zip(warm, cold, strict=True):
        assert w.sigma_h_m == pytest.approx(c.sigma_h_m, rel=2e-4)
