"""The one statement of (P) the back ends share (solver/problem.py): its ray and Cartesian
constraint functions agree with each other and with the independent checker, family by
family, at the certified optimum and at formations that break a family."""
from __future__ import annotations

import numpy as np
import pytest

from uav_insar_planner import model
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import default_params
from uav_insar_planner.solver import solve
from uav_insar_planner.solver.power import schedules
from uav_insar_planner.solver.problem import (
    cartesian_bounds,
    cartesian_slacks,
    make_problem,
    ray_slacks,
)

SCHEME = "proposed"
# Families both statements write as functions (C2, C3, C7 are bounds of the ray coordinates;
# C9-C11 are the station disk of the cheapest schedule in both).
COMMON = {"C1", "C4", "C5", "C6", "C8"}
TOL = 1e-7


@pytest.fixture(scope="module")
def optimum():
    p = default_params()
    return p, solve(p, scheme=SCHEME, objective="exact").formation


def _broken(tags) -> set[str]:
    return {tag for tag, g in tags if np.min(g) < -TOL}


def _cartesian(pr, q: np.ndarray) -> set[str]:
    return _broken(cartesian_slacks(pr, {k: (np.array(q[k, 0]), np.array(q[k, 1]))
                                         for k in pr.uavs}))


def _rays(pr, q: np.ndarray) -> set[str]:
    p, slaves = pr.p, list(pr.slaves)
    r0 = np.array([model.slant_range(q[0, 0], q[0, 1], p.x_t)])
    th = model.look_angle(q[slaves, 0], q[slaves, 1], p.x_t)[None]
    r = model.slant_range(q[slaves, 0], q[slaves, 1], p.x_t)[None]
    return _broken(ray_slacks(pr, r0, th, r))


def _checker(p, q: np.ndarray) -> set[str]:
    return set(evaluate(p, q, schedules(p, q, SCHEME), SCHEME).violated)


@pytest.mark.parametrize("change", ["none", "slave above z_max", "slave beside the master",
                                    "slave out along its ray"])
def test_the_statements_and_the_checker_name_the_same_broken_families(optimum, change):
    p, q = optimum
    q = q.copy()
    pr = make_problem(p, SCHEME, "exact")
    if change == "slave above z_max":
        q[1, 1] = p.z_max + 5.0
    elif change == "slave beside the master":
        q[2] = q[0] + [0.5 * p.d_min, 0.0]
    elif change == "slave out along its ray":
        q[1] = [p.x_t, 0.0] + 1.3 * (q[1] - [p.x_t, 0.0])   # past its C8 line
    expected = _checker(p, q) & COMMON
    assert (change == "none") == (not expected), expected
    assert _cartesian(pr, q) & COMMON == expected
    assert _rays(pr, q) & COMMON == expected


def test_the_cartesian_box_holds_the_certified_optimum(optimum):
    p, q = optimum
    pr = make_problem(p, SCHEME, "exact")
    v = [q[0, 1]] + [c for k in pr.slaves for c in q[k]]
    assert all(lo <= x <= hi for x, (lo, hi) in zip(v, cartesian_bounds(pr), strict=True))
    r0 = float(model.slant_range(q[0, 0], q[0, 1], p.x_t))
    assert pr.r0_lo <= r0 <= pr.r0_hi
    th = model.look_angle(q[list(pr.slaves), 0], q[list(pr.slaves), 1], p.x_t)
    assert np.all((th >= pr.th_lo) & (th <= pr.th_hi))


@pytest.mark.parametrize("scheme", ["proposed", "single-baseline"])
def test_the_c4_ray_slacks_are_every_pair_s_distance_in_order(scheme):
    """ray_slacks' C4 columns (pairs in np.triu_indices order, master first, built from a
    cached index) against each pair's distance taken one by one, on random points."""
    p = default_params()
    pr = make_problem(p, scheme, "exact")
    rng = np.random.default_rng(len(pr.slaves))
    k_count, m = len(pr.slaves), 7
    r0, th = rng.uniform(20.0, 200.0, m), rng.uniform(-1.2, 1.2, (m, k_count))
    r = rng.uniform(0.0, 300.0, (m, k_count))
    c4 = [g for tag, g in ray_slacks(pr, r0, th, r) if tag == "C4"]
    xs = np.concatenate([[[-pr.sin0]] * r0[:, None], -r * np.sin(th)], axis=1)
    zs = np.concatenate([[[np.cos(pr.th0)]] * r0[:, None], r * np.cos(th)], axis=1)
    want = [[(np.hypot(xs[n, a] - xs[n, b], zs[n, a] - zs[n, b]) ** 2 - p.d_min**2) / p.d_min
             for a in range(k_count + 1) for b in range(a + 1, k_count + 1)] for n in range(m)]
    assert len(c4) == 1
    np.testing.assert_allclose(c4[0], want, rtol=1e-12, atol=1e-9)
