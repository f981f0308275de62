"""Any number K of slaves: their ranges for given look angles, and the bound over a box.

A box is one row [r0_a, r0_b, theta_1a, theta_1b, ..., theta_Ka, theta_Kb] (columns
`angle_cols`). The objective is lambda r0 sin(theta_0) / (2 pi sqrt(sum_k w_k)), so a lower
bound on it over a box is an upper bound on sum_k w_k / r0^2 (slave_ranges.py).

Bound. The slaves interact only through C4 between themselves. Dropping C4 for every pair but
those of a matching M (disjoint pairs) relaxes the problem, so

    sum_k w_k <= sum_{(i,j) in M} W_ij + sum_{k unmatched} W_k

with W_k the one-slave bound and W_ij the pair bound (slave_ranges.pair_weight_bound, which
keeps C4 of the pair). Every matching gives a valid bound, so the least is taken over the
matchings of neighbours in the order of the boxes' angle midpoints (neighbours in angle are
the pairs that C4 couples) by the recursion

    B(0) = 0, B(1) = W_(1), B(i) = min(B(i-1) + W_(i), B(i-2) + W_(i-1)(i)).

With K = 2 this is the pair bound itself (W_12 <= W_1 + W_2).

Ranges. For K <= 2 slave_ranges.best_ranges is exact. For K >= 3 `greedy_ranges` gives a
feasible, not necessarily optimal, assignment (an incumbent: any feasible point is a valid
upper bound): each slave in turn at the top of its ray, stepped down to the lower crossing of
the C4 circle of every slave already placed that it would come too close to, and below the
master's hole (C4 to the master) if it lands in it.
"""
from __future__ import annotations

import numpy as np

from uav_insar_planner.solver.global_opt import slave_ranges
from uav_insar_planner.solver.rays import Scenario


def angle_cols(j: int) -> tuple[int, int]:
    """Columns (theta_a, theta_b) of slave j (0-based position in sc.slaves) in a box row."""
    return 2 + 2 * j, 3 + 2 * j


def box_lower_bound(sc: Scenario, boxes: np.ndarray) -> np.ndarray:
    """Lower bound on the objective over every feasible point of each box (+inf: the box
    provably holds none). C4 between a slave and the master is relaxed away."""
    r0a, r0b = boxes[:, 0], boxes[:, 1]
    pieces, single = [], []
    ok = np.ones(len(boxes), dtype=bool)
    for j, k in enumerate(sc.slaves):
        ta, tb = (boxes[:, c] for c in angle_cols(j))
        lo, up, smax, g_rg = slave_ranges.slave_box(sc, k, r0a, r0b, ta, tb)
        ok &= lo <= up
        pieces.append((lo, up, smax, g_rg, ta, tb))
        single.append(slave_ranges.weight_bound(sc, r0a, up, smax, g_rg))
    if len(single) == 1 or not sc.on("C4"):
        w = np.sum(single, axis=0)
    elif len(single) == 2:  # one matching: the pair (its bound never exceeds W_1 + W_2)
        w = slave_ranges.pair_weight_bound(sc, r0a, *pieces, *single)
    else:
        w = _matching_bound(sc, r0a, np.stack(pieces), np.stack(single))
    w = np.where(ok, w, -np.inf)
    return np.where(w > -np.inf, slave_ranges._from_normalised(sc, w), np.inf)


def _matching_bound(sc: Scenario, r0a, pieces: np.ndarray, single: np.ndarray) -> np.ndarray:
    """The recursion of the module docstring over neighbours in angle order; pieces is
    (K, 6, n) of slave_box's pieces and the angle interval, single (K, n)."""
    mid = pieces[:, 4] + pieces[:, 5]                     # (K, n): twice the angle midpoint
    order = np.argsort(mid, axis=0, kind="stable")
    pieces = np.take_along_axis(pieces, order[:, None, :], axis=0)
    single = np.take_along_axis(single, order, axis=0)
    prev2, prev1 = np.zeros_like(single[0]), single[0]
    for i in range(1, len(single)):
        pair = slave_ranges.pair_weight_bound(sc, r0a, pieces[i - 1], pieces[i],
                                              single[i - 1], single[i])
        with np.errstate(invalid="ignore"):  # -inf (an empty pair) + inf: the box is empty
            step = np.minimum(prev1 + single[i], prev2 + pair)
        prev2, prev1 = prev1, np.where(np.isnan(step), -np.inf, step)
    return prev1


def ranges_for(sc: Scenario, r0, thetas: np.ndarray):
    """(objective, ranges) for master ranges r0 (n,) and slave look angles thetas (n, K):
    the exact optimum for K <= 2, greedy_ranges' feasible point for K >= 3; objective +inf and
    ranges nan where none is found."""
    if len(sc.slaves) <= 2:
        cols = [thetas[:, j] for j in range(thetas.shape[1])]
        f, r1, r2 = slave_ranges.best_ranges(sc, r0, *cols)
        return f, np.stack([r1, r2][:len(cols)], axis=1)
    f1, r1 = greedy_ranges(sc, r0, thetas, range(len(sc.slaves)))
    f2, r2 = greedy_ranges(sc, r0, thetas, range(len(sc.slaves) - 1, -1, -1))
    take = f2 < f1
    return np.where(take, f2, f1), np.where(take[:, None], r2, r1)


def greedy_ranges(sc: Scenario, r0, thetas: np.ndarray, order) -> tuple[np.ndarray,
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
        (lo_a, top_a), (lo_b, top_b) = slave_ranges._components(sc, sc.slaves[j], r0,
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
                    r = np.where(clash, slave_ranges._lower_crossing(ri, c, d2), r)
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
        w = w + slave_ranges._slave_weight(sc, r0, thetas[:, j], ranges[:, j])
    f = np.where(ok & (w > 0), slave_ranges._from_normalised(sc, np.where(ok, w, 0.0)), np.inf)
    return f, ranges
