"""The box bound for K >= 3 slaves: C4 kept between every pair (K <= FOREST_MAX_K) or between
every pair of neighbours in angle (more slaves).

Relaxation (R) of a box: order the slaves by their angle intervals' midpoints, keep C4 only
between neighbours i, i+1 in that order, as the ellipse E_i = {r_i^2 + r_(i+1)^2 -
2 c_i r_i r_(i+1) < d_min^2} with c_i = cos of the largest angle difference in the box (it lies
inside every true exclusion ellipse of the pair), bound each slave's range by
[lo_k, up_k] and its weight by the non-decreasing W_k(r_k) (slave_ranges.slave_box and
weight_bound). Every feasible point of the box gives a feasible point of (R) with at least its
sum of weights, so max (R) bounds sum_k w_k / r0^2.

(R) is solved exactly. Each E_i is convex and contains the origin, so scaling a point of (R)
by t >= 1 keeps every pair outside its ellipse: some optimum has a slave at its top up_j.
Fixing it splits the chain; scaling one side alone by t >= 1 ends with a member at its top or
the member next to the fixed slave at its lower crossing y_lo of that slave's ellipse (from
below: above the upper crossing it could rise freely). By induction some optimum has every
slave i at a candidate: up_i, or the lower crossing propagated from some up_j along the chain
j -> ... -> i. So max (R) = max over candidate assignments with every neighbour pair outside
its ellipse of sum_k W_k, a dynamic programme over the chain with K states per slave:

    B_0(m) = W_0(cand_0m),  B_i(n) = W_i(cand_in) + max_{m compatible with n} B_(i-1)(m).

Compatibility is tested with a relative slack of 1e-9 on d_min^2: candidates sit on ellipse
boundaries, and rounding must not make (R) look smaller than it is. No compatible assignment
proves the box empty.

Limit of the chain: non-neighbouring pairs are relaxed away. Where they conflict at the
optimum (d_min comparable with the spacing of three slaves' rays, e.g. two slaves on one ray
d_min apart and a third beside them; found with d_min = 6 and 12 m) the chain bound stays
valid but does not converge as the boxes shrink. forest_weight_bound keeps every pair exactly
(the same argument, each slave at its top or at the lower crossing of any slave fixed before
it: the values of a rooted forest of "who is pressed by whom") and is used up to
FOREST_MAX_K slaves, with the master's hole as a further root (a slave pressed against the
master); with more, such a search ends at its node limit with an honest, larger gap.
"""
from __future__ import annotations

import functools
import itertools

import numpy as np

from uav_insar_planner.solver.global_opt import slave_ranges
from uav_insar_planner.solver.global_opt.kernel import lower_crossing
from uav_insar_planner.solver.problem import Problem

COMPAT_SLACK = 1e-9
TOP, HOLE = -1, -2  # root kinds of a forest: at the slave's top, at the master hole's lower end
# Up to this many slaves every pair keeps C4 (forest_weight_bound: (K + 1)^(K - 1) forests, 16
# for three slaves, 125 for four); beyond, the chain of angle neighbours (1296 forests for five
# slaves made a Table I solve 40x slower).
FOREST_MAX_K = 4


def chain_weight_bound(sc: Problem, r0a, pieces: np.ndarray) -> np.ndarray:
    """max (R) for each box: pieces is (K, 9, n), per slave (lo, up, smax, g_rg, theta_a,
    theta_b, h1, h2, C8 cap); -inf where (R) is infeasible."""
    order = np.argsort(pieces[:, 4] + pieces[:, 5], axis=0, kind="stable")
    cols = [0, 1, 2, 3, 4, 5, 8]  # the master's hole (h1, h2) is not used here
    lo, up, smax, g_rg, ta, tb, cap = np.take_along_axis(pieces[:, cols], order[:, None, :],
                                                         axis=0).transpose(1, 0, 2)
    k_count = len(lo)
    d2 = sc.p.d_min**2
    # c_i of the neighbour pair (i, i+1): cos of the largest angle difference in the box
    dmax = np.minimum(np.maximum(np.abs(tb[1:] - ta[:-1]), np.abs(tb[:-1] - ta[1:])), np.pi)
    c = np.cos(dmax)
    cand = _candidates(up, c, d2)                       # (K slaves, K sources, n)
    valid = (cand >= lo[:, None]) & (cand <= up[:, None])
    with np.errstate(invalid="ignore"):
        w = slave_ranges.weight_bound(sc, r0a, np.where(valid, cand, 0.0), smax[:, None],
                                      g_rg[:, None], cap[:, None])
    w = np.where(valid, w, -np.inf)
    best = w[0]
    for i in range(1, k_count):
        a, b = cand[i - 1][:, None], cand[i][None, :]   # (K, 1, n) x (1, K, n)
        with np.errstate(invalid="ignore"):
            ok = a * a + b * b - 2.0 * c[i - 1] * a * b >= d2 * (1.0 - COMPAT_SLACK)
        reach = np.max(np.where(ok, best[:, None], -np.inf), axis=0)
        with np.errstate(invalid="ignore"):
            best = np.where(np.isnan(reach + w[i]), -np.inf, reach + w[i])
    return np.max(best, axis=0)


def _candidates(up: np.ndarray, c: np.ndarray, d2: float) -> np.ndarray:
    """cand[i, j]: slave i's candidate started from up_j (cand[i, i] = up_i), the lower
    crossing passed along the chain; nan where a crossing does not exist."""
    k_count = len(up)
    cand = np.full((k_count, k_count) + up.shape[1:], np.nan)
    with np.errstate(invalid="ignore"):  # an unbounded top (families off) has no crossing
        _propagate(cand, up, c, d2)
    return cand


def _propagate(cand: np.ndarray, up: np.ndarray, c: np.ndarray, d2: float) -> None:
    k_count = len(up)
    for j in range(k_count):
        cand[j, j] = up[j]
        for i in range(j + 1, k_count):                  # rightwards from j
            cand[i, j] = lower_crossing(cand[i - 1, j], c[i - 1], d2)
        for i in range(j - 1, -1, -1):                   # leftwards from j
            cand[i, j] = lower_crossing(cand[i + 1, j], c[i], d2)


# --- every pair kept: rooted forests of "who is pressed by whom" -------------------------------

@functools.cache
def _forests(k_count: int, hole: bool = True):
    """The rooted forests on K slaves as ancestor paths: paths[(kind, root, ..., i)] index,
    and for each forest the path index of every slave ((F, K) array). A slave is a root, at its
    top (kind TOP) or at the lower end of the master's hole (kind HOLE), or pressed by its
    parent (at the lower crossing of the parent's ellipse). hole=False: no HOLE roots (for
    boxes where the master's hole excludes nothing)."""
    paths: dict[tuple[int, ...], int] = {}
    table = []
    for parents in itertools.product(range(HOLE if hole else TOP, k_count), repeat=k_count):
        chains = []
        for i in range(k_count):
            chain, j = [i], parents[i]
            while j >= 0 and j not in chain:
                chain.append(j)
                j = parents[j]
            if j >= 0:
                break  # a cycle: not a forest
            chains.append((j,) + tuple(reversed(chain)))
        else:
            table.append([paths.setdefault(c, len(paths)) for c in chains])
    return tuple(paths), np.array(table)


def forest_weight_bound(sc: Problem, r0a, pieces: np.ndarray) -> np.ndarray:
    """See _forest_totals. Boxes where the master's hole excludes nothing for any slave need
    only the forests without HOLE roots (125 instead of 432 for four slaves)."""
    hole = np.isfinite(pieces[:, 6]).any(axis=0)
    out = np.empty(len(r0a))
    for sel, with_hole in ((hole, True), (~hole, False)):
        if sel.any():
            total, _ = _forest_totals(sc, r0a[sel], pieces[:, :, sel], with_hole)
            out[sel] = np.max(total, axis=0)
    return out


def forest_ranges(sc: Problem, r0a, pieces: np.ndarray) -> np.ndarray:
    """The ranges (n, K) of the best forest for point boxes (theta_a = theta_b, r0 fixed),
    where the relaxation is the inner problem itself apart from the master's hole and
    rounding, which the caller checks; nan where no forest fits."""
    total, vals = _forest_totals(sc, r0a, pieces)
    best = np.argmax(total, axis=0)
    ranges = vals[best, :, np.arange(total.shape[1])]
    return np.where(np.isfinite(total.max(axis=0))[:, None], ranges, np.nan)


def _forest_totals(sc: Problem, r0a, pieces: np.ndarray, with_hole: bool = True):
    """max of the relaxation that keeps C4 between every pair of slaves (with each pair's
    largest angle difference in the box): the argument of the module docstring, fixing one
    slave at a time, ends with every slave at its top or at the lower crossing of an
    already fixed slave, i.e. at the values of a rooted forest; -inf where none is
    compatible. pieces as for chain_weight_bound."""
    lo, up, smax, g_rg, ta, tb, h1, h2, cap = pieces.transpose(1, 0, 2)
    k_count = len(lo)
    d2 = sc.p.d_min**2
    dmax = np.minimum(np.maximum(np.abs(tb[:, None] - ta[None]), np.abs(tb[None] - ta[:, None])),
                      np.pi)
    c = np.cos(dmax)                                         # (K, K, n)
    paths, table = _forests(k_count, with_hole)
    val = np.empty((len(paths),) + up.shape[1:])
    with np.errstate(invalid="ignore"):
        for p, (kind, *path) in enumerate(paths):
            v = up[path[0]] if kind == TOP else h1[path[0]]
            for a, b in zip(path[:-1], path[1:], strict=True):
                v = lower_crossing(v, c[a, b], d2)
            val[p] = v
        last = np.array([path[-1] for path in paths])
        ok = ((val >= lo[last]) & (val <= up[last])
              & ~((val > h1[last]) & (val < h2[last])))
        w = slave_ranges.weight_bound(sc, r0a, np.where(ok, val, 0.0), smax[last], g_rg[last],
                                      cap[last])
    w = np.where(ok, w, -np.inf)
    vals = val[table]                                        # (F, K, n)
    total = np.sum(w[table], axis=1)                         # (F, n)
    for i, j in itertools.combinations(range(k_count), 2):
        a, b = vals[:, i], vals[:, j]
        with np.errstate(invalid="ignore"):
            fits = a * a + b * b - 2.0 * c[i, j] * a * b >= d2 * (1.0 - COMPAT_SLACK)
        total = np.where(fits, total, -np.inf)
    with np.errstate(invalid="ignore"):
        total = np.where(np.isnan(total), -np.inf, total)
    return total, vals
