"""What a speed step carries (solver/global_opt/speed_carry.py, warm.speed_restricts): every
carried bound is a lower bound at the new speed wherever it is sampled, the carried boxes
cover the new domain, and warm fronts in random speed orders, up and down, certify the cold
optimum at every point with a lower bound that never passes it."""
from __future__ import annotations

import numpy as np
import pytest

from uav_insar_planner.params_file import load_params
from uav_insar_planner.solver import new_warm_start, solve
from uav_insar_planner.solver.global_opt import slave_sets, speed_carry, warm
from uav_insar_planner.solver.problem import make_problem
from uav_insar_planner.survey.speed import speed_front


@pytest.fixture(scope="module")
def table1():
    return load_params()


def _solved(p, v: float) -> warm.WarmStart:
    state = new_warm_start("global")
    solve(p.replace(speed_mps=v), warm_start=state)
    return state


def _problem(p, v: float):
    return make_problem(p.replace(speed_mps=v), p.scheme, p.objective)


def test_a_step_up_restricts_only_where_no_station_disk_grows(table1):
    """Table I: C11's disk grows with v up to 2.82 m/s and shrinks past it; a step down
    raises gamma_m (sigma_h falls, C6 widens): never a restriction."""
    def restricts(v: float, v2: float) -> bool:
        state = warm.WarmStart()
        warm.remember(state, _problem(table1, v), None, None)
        return warm.restricts(state, _problem(table1, v2))

    assert restricts(3.0, 3.25) and restricts(4.5, 4.75) and restricts(3.0, 8.0)
    assert not restricts(1.0, 1.25) and not restricts(2.0, 2.75)
    assert not restricts(3.25, 3.0) and not restricts(1.25, 1.0)


def _inside_domain(sc, boxes: np.ndarray) -> np.ndarray:
    lo = np.array([sc.r0_lo] + [sc.th_lo] * len(sc.slaves))
    hi = np.array([sc.r0_hi] + [sc.th_hi] * len(sc.slaves))
    cut = boxes.copy()
    cut[:, 0::2] = np.maximum(cut[:, 0::2], lo)
    cut[:, 1::2] = np.minimum(cut[:, 1::2], hi)
    return cut


def _sampled_values(sc, boxes: np.ndarray, rng) -> np.ndarray:
    """sigma_h at one random point of each box (a corner in a quarter of the draws), with
    the slaves' exact best ranges there (slave_ranges.best_ranges): at least the minimum over
    the box's feasible points at those angles; inf where there are none."""
    u = rng.random((len(boxes), boxes.shape[1] // 2))
    corner = rng.random(len(boxes)) < 0.25
    u[corner] = np.round(u[corner])
    pts = boxes[:, 0::2] + (boxes[:, 1::2] - boxes[:, 0::2]) * u
    f, _ = slave_sets.ranges_for(sc, pts[:, 0], pts[:, 1:])
    return f


@pytest.mark.parametrize("v, v2, share", [
    (1.0, 1.25, 0.9), (1.25, 1.0, 0.9), (3.0, 3.25, 0.9), (3.25, 3.0, 0.9), (4.5, 4.75, 0.9),
    (2.0, 3.5, 0.9), (4.0, 1.0, 0.8),
    (4.75, 4.5, 0.0)])  # C9's disk at 4.5 m/s reaches past 4.75 m/s's: not carried
def test_every_carried_bound_holds_where_it_is_sampled(table1, v, v2, share):
    """Up and down, restricting or not, near the optimum and far from it: sigma_h at the new
    speed is at least the carried bound (rho_B lb(B), or inf for a box kept empty) at every
    point drawn in a carried box of the new domain; at least `share` of the boxes carried."""
    state = _solved(table1, v)
    sc = _problem(table1, v2)
    restricted = warm.restricts(state, sc)
    bound = speed_carry.carried(state.problem, sc, state.leaves, state.leaf_lb, restricted)
    carried = bound > -np.inf
    assert carried.mean() >= share
    boxes = _inside_domain(sc, state.leaves[carried])
    ok = np.all(boxes[:, 0::2] <= boxes[:, 1::2], axis=1)
    rng = np.random.default_rng(11)
    for _ in range(40):
        f = _sampled_values(sc, boxes[ok], rng)
        assert np.all(f >= bound[carried][ok] * (1.0 - 1e-12))


@pytest.mark.parametrize("v, v2", [(1.25, 1.5), (1.5, 1.25), (3.0, 3.25)])
def test_the_first_boxes_of_a_speed_step_cover_the_domain_and_bound_it(table1, v, v2):
    """speed_carry.boxes (moved with the optimum, bounded afresh, or in place with their
    bounds carried): every point of the new domain with ordered angles lies in a box (drawn
    uniformly and about the new optimum), and every carried bound holds where sampled."""
    state = _solved(table1, v)
    sc = _problem(table1, v2)
    point = _solved(table1, v2).point
    boxes, bounds, partial = warm.speed_boxes(sc, state, point, warm.restricts(state, sc))
    assert boxes is not None and not partial
    rng = np.random.default_rng(5)
    lo = np.array([sc.r0_lo] + [sc.th_lo] * 2)
    hi = np.array([sc.r0_hi] + [sc.th_hi] * 2)
    y = lo + (hi - lo) * rng.random((3000, 3))
    y[:, 1:] = np.sort(y[:, 1:], axis=1)  # interchangeable slaves: ordered angles
    near = np.array(point[:1] + point[1]) + rng.normal(0.0, 1e-3, (3000, 3)) * (hi - lo)
    for pts in (y, np.clip(near, lo, hi)):
        pts[:, 1:] = np.sort(pts[:, 1:], axis=1)
        inside = np.all((boxes[None, :, 0::2] <= pts[:, None]) & (pts[:, None]
                                                                 <= boxes[None, :, 1::2]), axis=2)
        assert inside.any(axis=1).all()
    if bounds is None:  # moved: every bound afresh
        assert v2 < 2.82
        return
    held = bounds > -np.inf
    for _ in range(20):
        f = _sampled_values(sc, boxes[held], rng)
        assert np.all(f >= bounds[held] * (1.0 - 1e-12))


@pytest.mark.parametrize("seed", [1, 2])
def test_random_speed_orders_certify_the_cold_optimum(table1, seed):
    """Warm fronts over random speeds in random order (steps up and down, small and large,
    across the 2.82 m/s turn of C11's disk and the 4.76 m/s feasibility edge): the same
    feasibility, each optimum within the other's certificate, and the warm lower bound never
    above the cold optimum (an invalid carried bound would push it there)."""
    rng = np.random.default_rng(seed)
    speeds = [float(v) for v in rng.uniform(0.3, 5.3, 9)]
    speeds += [speeds[-1] + 0.2, speeds[-1], 1.0, 1.25, 1.0, 3.25, 3.0, 3.25]
    hot, cold = speed_front(table1, speeds), speed_front(table1, speeds, warm=False)
    for w, c in zip(hot, cold, strict=True):
        assert w.feasible == c.feasible, w.speed_mps
        if not c.feasible:
            assert w.lower_bound_m == c.lower_bound_m == float("inf")
            continue
        assert w.optimality_gap <= 1e-4 and c.optimality_gap <= 1e-4
        assert w.lower_bound_m <= c.sigma_h_m and c.lower_bound_m <= w.sigma_h_m
        assert w.sigma_h_m == pytest.approx(c.sigma_h_m, rel=1e-4)


def test_a_front_up_past_the_turn_of_c11_starts_each_point_from_carried_bounds(table1):
    """Table I at 3-4 m/s: each step restricts (P), its first boxes are the previous ones with
    their bounds carried, and most of those close at the new optimum without a fresh bound;
    the answers are the cold ones."""
    state = new_warm_start("global")
    for v in (3.0, 3.25, 3.5, 4.0):
        sc = _problem(table1, v)
        cold = solve(table1.replace(speed_mps=v))
        if v > 3.0:
            assert warm.restricts(state, sc)
            _, bounds, _ = warm.speed_boxes(sc, state, _solved(table1, v).point, True)
            assert np.mean(bounds >= cold.sigma_h_m * (1.0 - 5e-5)) > 0.8
        hot = solve(table1.replace(speed_mps=v), warm_start=state)
        assert state.used_leaves == (v > 3.0)
        assert hot.sigma_h_m == pytest.approx(cold.sigma_h_m, rel=1e-4)
        assert hot.lower_bound_m <= cold.sigma_h_m
