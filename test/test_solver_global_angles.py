"""The cut of each slave's look angles to its provably feasible ones (solver/global_opt/
angle_domain.py): it never drops a feasible angle, the box bound with it stays below the
objective at every sampled feasible point, and it ends the grind along a slave's feasibility
edge (Figure 3's static-power points)."""
from __future__ import annotations

import numpy as np
import pytest

from uav_insar_planner.params import default_params
from uav_insar_planner.solver import solve
from uav_insar_planner.solver.global_opt import angle_domain, slave_sets
from uav_insar_planner.solver.global_opt.kernel import range_components
from uav_insar_planner.solver.problem import make_problem

FIG3 = {"master_fixed_xz_m": [-54.0, 74.0], "p_com_max_db": 10.1}
CASES = [
    ("static-power", {**FIG3, "h_amb_min_m": 0.7}),  # slave 1 on the C5 / station-disk crossing
    ("static-power", {**FIG3, "h_amb_min_m": 0.5}),
    ("proposed", {**FIG3, "h_amb_min_m": 0.6}),
    ("proposed", {}),                                   # Table I
    ("fixed-master", {}),
    ("static-power", {"p_com_max_db": 9.0, "d_min_m": 6.0}),
    ("single-baseline", {}),
    ("proposed", {"num_uavs": 4, "rate_min_mbps": [10.0, 16.95, 1.0, 1.0], "d_min_m": 4.0}),
]


def _problem(scheme, overrides):
    return make_problem(default_params().replace(**overrides), scheme, "exact")


def _has_range(sc, k, r0, th):
    (lo_a, top_a), (lo_b, top_b) = range_components(sc, k, r0, th)
    return (lo_a <= top_a) | (lo_b <= top_b)


def _true_edges(sc, j, kept):
    """Each kept interval's end inside the domain, taken by bisection of the exact ray model
    (a feasible range at some master range of a fine grid) to the edge of the slave's feasible
    angles nearby: nan where the angle just inside is not feasible (the kept set is a
    superset there)."""
    k, w = sc.slaves[j], sc.th_hi - sc.th_lo
    r0 = np.linspace(sc.r0_lo, sc.r0_hi, 41)[:, None]
    out = []
    for end, inward in [(e, 1.0) for e in kept[j][:, 0]] + [(e, -1.0) for e in kept[j][:, 1]]:
        if not sc.th_lo < end < sc.th_hi:
            continue
        outer, inner = end - inward * 1e-12, end + inward * 1e-5 * w
        if not np.any(_has_range(sc, k, r0, np.array([inner]))):
            out.append(np.nan)
            continue
        for _ in range(80):
            mid = 0.5 * (outer + inner)
            if np.any(_has_range(sc, k, r0, np.array([mid]))):
                inner = mid
            else:
                outer = mid
        out.append(inner)
    return np.array(out)


def _inside(intervals, th):
    if not len(intervals):
        return np.zeros(th.shape, dtype=bool)
    i = np.clip(np.searchsorted(intervals[:, 0], th, side="right") - 1, 0, None)
    return (th >= intervals[i, 0]) & (th <= intervals[i, 1])


@pytest.mark.parametrize(("scheme", "overrides"), CASES)
def test_no_feasible_angle_is_dropped(scheme, overrides):
    """Every angle of a fine grid (and random ones) with a feasible range at some master range
    of a fine grid lies in the kept intervals; and the cut is not vacuous where the edge is
    known."""
    sc = _problem(scheme, overrides)
    kept = angle_domain.feasible_angles(sc)
    rng = np.random.default_rng(1)
    th = np.concatenate([np.linspace(sc.th_lo, sc.th_hi, 20001),
                         rng.uniform(sc.th_lo, sc.th_hi, 20000)])
    r0 = np.linspace(sc.r0_lo, sc.r0_hi, 41) if sc.r0_hi > sc.r0_lo else np.array([sc.r0_lo])
    for j, k in enumerate(sc.slaves):
        feasible = np.any(_has_range(sc, k, r0[:, None], th[None, :]), axis=0)
        assert np.all(_inside(kept[j], th[feasible])), (k, th[feasible & ~_inside(kept[j], th)])
        assert np.all(np.diff(kept[j].ravel()) >= 0)  # sorted and disjoint
        edges = _true_edges(sc, j, kept)
        edges = edges[np.isfinite(edges)]
        assert np.all(_inside(kept[j], edges)), (k, edges, kept[j])  # the edge itself is kept
    if scheme == "static-power" and overrides.get("h_amb_min_m") == 0.7:
        # slave 1's edge: C5's floor meets its station disk at 0.685189 rad
        assert abs(kept[0][0, 0] - 0.6851887) < 1e-6


@pytest.mark.parametrize(("scheme", "overrides"), CASES)
def test_cut_box_bound_holds_at_random_feasible_points(scheme, overrides):
    """Thousands of random boxes, many straddling a slave's feasibility edge: the bound with
    the cut is at most the objective of every sampled feasible point of the box (the exact
    inner optimum for K <= 2, a feasible placement beyond), and no box holding one is called
    empty."""
    sc = _problem(scheme, overrides)
    kept = angle_domain.feasible_angles(sc)
    rng = np.random.default_rng(7)
    k_count, n, per_box = len(sc.slaves), 3000, 12
    true = [_true_edges(sc, j, kept) for j in range(k_count)]
    edges = np.concatenate([kept[j].ravel() for j in range(k_count)] + true)
    edges = edges[np.isfinite(edges)]
    centre = np.where(rng.uniform(size=(n, k_count)) < 0.5, rng.choice(edges, (n, k_count)),
                      rng.uniform(sc.th_lo, sc.th_hi, (n, k_count)))
    half = 10.0 ** rng.uniform(-10, -1.5, (n, k_count))
    ta = np.clip(centre - half * rng.uniform(size=(n, k_count)), sc.th_lo, sc.th_hi)
    tb = np.clip(ta + 2 * half, sc.th_lo, sc.th_hi)
    span = sc.r0_hi - sc.r0_lo
    r0a = sc.r0_lo + span * rng.uniform(0, 0.3, n) ** 2
    r0b = np.minimum(sc.r0_hi, r0a + span * 10.0 ** rng.uniform(-5, -1, n))
    boxes = np.column_stack([r0a, r0b] + [c for j in range(k_count) for c in (ta[:, j], tb[:, j])])
    lb = slave_sets.box_lower_bound(sc, boxes, angles=kept)
    lb_plain = slave_sets.box_lower_bound(sc, boxes)
    assert np.all(lb >= lb_plain * (1 - 1e-12))  # the cut only tightens
    u = rng.uniform(size=(per_box, n, 1 + k_count))
    r0s = r0a + (r0b - r0a) * u[:, :, 0]
    ths = ta + (tb - ta) * u[:, :, 1:]
    ths[0] = ta  # box corners too, where an edge sits
    ths[1] = tb
    for j in range(k_count):  # the exact edges inside the box, where a loose cut would show
        for i, e in enumerate(true[j][np.isfinite(true[j])][:per_box - 2]):
            ths[2 + i, :, j] = np.clip(e, ta[:, j], tb[:, j])
    f, _ = slave_sets.ranges_for(sc, r0s.ravel(), ths.reshape(-1, k_count))
    f = f.reshape(per_box, n)
    feasible = np.isfinite(f)
    assert feasible.sum() > 500
    assert np.all(lb[None, :] <= np.where(feasible, f, np.inf) * (1 + 1e-12))
    assert np.all(np.isfinite(lb[feasible.any(axis=0)]))


@pytest.mark.parametrize("h", [0.5, 0.6, 0.7])
def test_static_power_fig3_points_close_without_the_grind(h):
    """The points that ground along slave 1's edge (88 806, 171 814 and 233 602 boxes before
    the cut) close in a few thousand, at the same optimum."""
    p = default_params().replace(**FIG3, h_amb_min_m=h)
    plan = solve(p, scheme="static-power", objective="exact", solver="global")
    assert plan.feasible and plan.iterations < 20_000
    assert plan.optimality_gap <= 5e-5
    reference = {0.5: 0.0382539491, 0.6: 0.0427644231, 0.7: 0.0465197694}[h]  # before the cut
    assert plan.sigma_h_m == pytest.approx(reference, rel=5e-5)
