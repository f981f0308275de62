"""Any number K of slaves: their ranges for given look angles, and the bound over a box.

A box is one row [r0_a, r0_b, theta_1a, theta_1b, ..., theta_Ka, theta_Kb] (columns
`angle_cols`). The objective is lambda r0 sin(theta_0) / (2 pi sqrt(sum_k w_k)), so a lower
bound on it over a box is an upper bound on sum_k w_k / r0^2 (slave_ranges.py).

Bound. The slaves interact only through C4 between themselves (C4 to the master is kept
through slave_ranges.slave_box, which lowers a top that the master's hole covers throughout
the box). One slave: its weight bound W_k. Two: the pair bound (slave_ranges.pair_weight_bound,
exact for the relaxation that keeps their C4 through the box's smallest cos). Three or four:
chain_bound.forest_weight_bound keeps C4 between every pair and solves that relaxation exactly
over the rooted forests of "who is pressed by whom"; five or more: chain_weight_bound keeps it
between neighbours in angle (a dynamic programme over candidate ranges). With one or two
slaves and C8 on, the total is also at most the sum of each slave's C8-capped bound
(slave_ranges.capped_weight_bound: its weight along the capped ray, maximised over the box's
angles through concavity), tight to second order in the angle width where both sit on the cap.

Ranges. For K <= 2 slave_ranges.best_ranges is exact. For K >= 3 `greedy_ranges` gives a
feasible, not necessarily optimal, assignment (an incumbent: any feasible point is a valid
upper bound): each slave in turn at the top of its ray, stepped down to the lower crossing of
the C4 circle of every slave already placed that it would come too close to, and below the
master's hole (C4 to the master) if it lands in it.
"""
from __future__ import annotations

import numpy as np

from uav_insar_planner.solver.global_opt import angle_domain, chain_bound, slave_ranges
from uav_insar_planner.solver.global_opt.kernel import (
    lower_crossing,
    objective_from_normalised,
    range_components,
    slave_weight,
)
from uav_insar_planner.solver.problem import Problem

# The C8-capped bound (slave_ranges.capped_weight_bound) costs ~40 us a call whatever the
# number of boxes; below this many open boxes a round gains less than that (Table I: 4.7
# instead of 4.0 ms when always on; Figure 3's proposed scheme at h_amb_min 0.5-0.7 m: 3 instead
# of 23-28 ms).
CAPPED_MIN_OPEN = 128


def angle_cols(j: int) -> tuple[int, int]:
    """Columns (theta_a, theta_b) of slave j (0-based position in sc.slaves) in a box row."""
    return 2 + 2 * j, 3 + 2 * j


def box_lower_bound(sc: Problem, boxes: np.ndarray, close_at: float = np.inf,
                    angles: list[np.ndarray] | None = None) -> np.ndarray:
    """Lower bound on the objective over every feasible point of each box (+inf: the box
    provably holds none); see the module docstring. close_at: bounds at or above it close the
    box anyway, so the costlier forest bound is spent only on boxes below it. angles: per
    slave, angle_domain.feasible_angles' intervals; each box's angles are cut to their hull
    first (every feasible point of the box lies in the cut box, so the bound of the cut box
    bounds it; a box whose angles miss them is empty)."""
    r0a, r0b = boxes[:, 0], boxes[:, 1]
    ta, tb = boxes[:, 2::2].T, boxes[:, 3::2].T  # (K, n): one row per slave
    caps = np.array([slave_ranges.c8_cap(sc, k) for k in sc.slaves])  # per slave: its rung
    ca, cb = angle_domain.clip_to_cap(sc, r0b, ta, tb, caps[:, None])
    if angles is not None:
        cut = [angle_domain.clip_to_feasible(a, ca[j], cb[j]) for j, a in enumerate(angles)]
        ca, cb = np.stack([c[0] for c in cut]), np.stack([c[1] for c in cut])
    hit = np.all(ca <= cb, axis=0)  # elsewhere some slave has no angle left: the box is empty
    if hit.all():
        return _cut_box_bound(sc, r0a, r0b, ca, cb, caps, close_at)
    # Along a sweep that tightens C8 most carried boxes it proves empty are proven so here
    # (Figure 3: a third of the boxes bounded), before the costlier rest of the bound.
    lb = np.full(len(boxes), np.inf)
    if hit.any():
        lb[hit] = _cut_box_bound(sc, r0a[hit], r0b[hit], ca[:, hit], cb[:, hit], caps, close_at)
    return lb


def _cut_box_bound(sc: Problem, r0a: np.ndarray, r0b: np.ndarray, ta: np.ndarray,
                   tb: np.ndarray, caps: np.ndarray, close_at: float) -> np.ndarray:
    """box_lower_bound of boxes whose slave angles [ta, tb] (K, n) are cut already."""
    lo, up, smax, g_rg = slave_ranges.slave_box(sc, tuple(sc.slaves), r0a, r0b, ta, tb)
    ok = np.all(lo <= up, axis=0)
    single = slave_ranges.weight_bound(sc, r0a, up, smax, g_rg, caps[:, None])
    if len(single) == 1 or not sc.on("C4"):
        w = np.sum(single, axis=0)
    elif len(single) == 2:  # one matching: the pair (its bound never exceeds W_1 + W_2)
        pieces = [(lo[j], up[j], smax[j], g_rg[j], ta[j], tb[j]) for j in range(2)]
        w = slave_ranges.pair_weight_bound(sc, r0a, *pieces, single[0], single[1],
                                           caps=(caps[0], caps[1]))
    else:
        h1, h2 = slave_ranges.master_hole_box(sc, r0a, r0b, ta, tb)
        stacked = np.stack([lo, up, smax, g_rg, ta, tb, np.broadcast_to(h1, ta.shape),
                            np.broadcast_to(h2, ta.shape),
                            np.broadcast_to(caps[:, None], ta.shape)], axis=1)
        w = chain_bound.chain_weight_bound(sc, r0a, stacked)
        if len(single) <= chain_bound.FOREST_MAX_K:
            # the forest keeps every pair and the master's hole: never looser than the chain
            with np.errstate(divide="ignore"):
                open_ = ok & (objective_from_normalised(sc, np.maximum(w, 0.0)) < close_at)
            if open_.any():
                w[open_] = np.minimum(w[open_], chain_bound.forest_weight_bound(
                    sc, r0a[open_], stacked[:, :, open_]))
    w = np.where(ok, w, -np.inf)
    if len(single) <= 2 and sc.on("C8"):
        # each slave's weight is at most its C8-capped bound: the sum caps the total; worth
        # computing only where the box stays open
        with np.errstate(divide="ignore"):
            open_ = ok & (objective_from_normalised(sc, np.maximum(w, 0.0)) < close_at)
        if open_.sum() >= CAPPED_MIN_OPEN:
            w[open_] = np.minimum(w[open_], np.sum(slave_ranges.capped_weight_bound(
                sc, r0a[open_], ta[:, open_], tb[:, open_], caps[:, None]), axis=0))
    return np.where(w > -np.inf, objective_from_normalised(sc, w), np.inf)


def ranges_for(sc: Problem, r0, thetas: np.ndarray):
    """(objective, ranges) for master ranges r0 (n,) and slave look angles thetas (n, K):
    the exact optimum for K <= 2, greedy_ranges' feasible point for K >= 3; objective +inf and
    ranges nan where none is found."""
    if len(sc.slaves) <= 2:
        cols = [thetas[:, j] for j in range(thetas.shape[1])]
        f, r1, r2 = slave_ranges.best_ranges(sc, r0, *cols)
        return f, np.stack([r1, r2][:len(cols)], axis=1)
    k_count = len(sc.slaves)
    tries = [greedy_ranges(sc, r0, thetas, range(k_count)),
             greedy_ranges(sc, r0, thetas, range(k_count - 1, -1, -1))]
    if k_count <= chain_bound.FOREST_MAX_K:
        tries.append(_forest_point(sc, r0, thetas))
    f, ranges = tries[0]
    for f_try, r_try in tries[1:]:
        take = f_try < f
        f, ranges = np.where(take, f_try, f), np.where(take[:, None], r_try, ranges)
    return f, ranges


def _forest_point(sc: Problem, r0, thetas: np.ndarray):
    """The best forest of chain_bound at fixed angles (the inner optimum up to the master's
    hole), kept where it passes the feasibility check of `_objective_if_feasible`."""
    r0 = np.asarray(r0, dtype=float)
    pieces = np.stack([np.stack(slave_ranges.slave_box(sc, k, r0, r0, th, th) + (th, th)
                                + slave_ranges.master_hole_box(sc, r0, r0, th, th)
                                + (np.full_like(th, slave_ranges.c8_cap(sc, k)),))
                       for j, k in enumerate(sc.slaves) for th in [thetas[:, j]]])
    with np.errstate(invalid="ignore", divide="ignore"):
        ranges = chain_bound.forest_ranges(sc, r0, pieces)
    return _objective_if_feasible(sc, r0, thetas, ranges)


def _objective_if_feasible(sc: Problem, r0, thetas: np.ndarray, ranges: np.ndarray):
    """(objective, ranges) with +inf / nan rows where the ranges break a ray limit, the
    master's hole or C4 between slaves."""
    d2 = sc.p.d_min**2 if sc.on("C4") else 0.0
    ok = np.all(np.isfinite(ranges), axis=1) & (r0 > 0)
    with np.errstate(invalid="ignore"):
        for j, k in enumerate(sc.slaves):
            (lo_a, top_a), (lo_b, top_b) = range_components(sc, k, r0, thetas[:, j])
            r = ranges[:, j]
            ok &= ((r >= lo_a) & (r <= top_a)) | ((r >= lo_b) & (r <= top_b))
            for i in range(j):
                c = np.cos(thetas[:, i] - thetas[:, j])
                ri = ranges[:, i]
                ok &= ri * ri + r * r - 2.0 * c * ri * r >= d2 * (1.0 - 1e-12)
    ranges = np.where(ok[:, None], ranges, np.nan)
    w = np.zeros(len(ranges))
    for j in range(ranges.shape[1]):
        w = w + slave_weight(sc, r0, thetas[:, j], ranges[:, j])
    f = np.where(ok & (w > 0), objective_from_normalised(sc, np.where(ok, w, 0.0)), np.inf)
    return f, ranges


def greedy_ranges(sc: Problem, r0, thetas: np.ndarray, order) -> tuple[np.ndarray,
                                                                         np.ndarray]:
    """A feasible assignment of the slaves' ranges, placing them in `order` (module
    docstring); (objective, ranges (n, K)), +inf / nan where it fails."""
    r0 = np.asarray(r0, dtype=float)
    d2 = sc.p.d_min**2 if sc.on("C4") else 0.0
    n, k_count = thetas.shape
    ranges = np.full((n, k_count), np.nan)
    ok = r0 > 0
    placed: list[int] = []
    for j in order:
        (lo_a, top_a), (lo_b, top_b) = range_components(sc, sc.slaves[j], r0,
                                                                thetas[:, j])
        r = np.where(lo_b <= top_b, top_b, top_a)
        hole_top = np.where(lo_b <= top_b, lo_b, np.inf)  # above it lies the upper component
        cos = [np.cos(thetas[:, i] - thetas[:, j]) for i in placed]
        for _ in range(len(placed) + 1):  # each pass only lowers r; stop when none clashes
            moved = False
            for i, c in zip(placed, cos, strict=True):
                ri = ranges[:, i]
                with np.errstate(invalid="ignore"):
                    clash = ri * ri + r * r - 2.0 * c * ri * r < d2
                if clash.any():
                    moved = True
                    r = np.where(clash, lower_crossing(ri, c, d2), r)
            r = np.where((r < hole_top) & (r > top_a), top_a, r)
            if not moved:
                break
        with np.errstate(invalid="ignore"):
            fits = (r >= lo_a) & (r <= np.maximum(top_a, top_b)) & ((r <= top_a) | (r >= lo_b))
        for i, c in zip(placed, cos, strict=True):
            ri = ranges[:, i]
            with np.errstate(invalid="ignore"):
                fits &= ri * ri + r * r - 2.0 * c * ri * r >= d2 * (1.0 - 1e-12)
        ok &= fits
        ranges[:, j] = r
        placed.append(j)
    ranges[~ok] = np.nan
    w = np.zeros(n)
    for j in range(k_count):
        w = w + slave_weight(sc, r0, thetas[:, j], ranges[:, j])
    f = np.where(ok & (w > 0), objective_from_normalised(sc, np.where(ok, w, 0.0)), np.inf)
    return f, ranges
