"""A lower bound for many interchangeable slaves from the structure of their optimum: a chain
of slaves on the C8 line, each d_min from the next.

Coordinates. In the master's frame a slave at (r, theta) has u = r cos(theta - theta_0) along
the master's line of sight and b = r sin(theta - theta_0) across it (|b| = b_perp). C8 caps
|b| <= cap r0 (slave_ranges.c8_cap), a line parallel to the master's line of sight, and C4
between two slaves is the Euclidean distance in (u, b).

Relaxation of a master interval r0 in [r0a, r0b]: every slave gets the largest station disk
and the loosest C8 cap of the slaves (`relaxed`), so all are interchangeable. With
B = cap r0b and a strip width delta < d_min, every slave is in one of three places:
- the upper strip B - delta < b <= B or the lower one -B <= b < -(B - delta): two slaves in
  one strip differ by less than delta in b, so by at least d' = sqrt(d_min^2 - delta^2) in u;
- the rest, |b| <= B - delta, where the weight is smaller (b_perp below the cap).
Cut u into columns of width h. A strip's cell (one column) bounds the weight of every slave
in it, W(c), by the monotonicity of every factor (kernel.py: b_perp at the cell's largest |b|
over the smallest r0, gamma_Rg at the angle nearest theta_0, gamma_SNR at the smallest r0
and range), and the C1-C11 ray limits over the cell's angles (slave_ranges.slave_box) prove
cells empty. Slaves of one strip sorted by u sit in columns at least g = ceil(d'/h) - 1 apart,
so m of them weigh at most F_m, the best sum of W over m columns g apart (a dynamic programme
with a running maximum, O(columns) per slave). The rest weigh at most W_rest each. So

    sum_k w_k / r0^2 <= max over m1 + m2 + m3 = m of F+_m1 + F-_m2 + m3 W_rest,

and the objective (free of r0 in these units) is at least its value there. The bound tightens
as the r0 interval shrinks (only r0 is searched, by bisection): it misses the optimum by the
column width per slave along the chain (h = CELL_M) and by the strip's slack d_min - d'.
"""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from uav_insar_planner.solver import rays
from uav_insar_planner.solver.global_opt import local_refine, slave_ranges, slave_sets
from uav_insar_planner.solver.global_opt.kernel import objective_from_normalised
from uav_insar_planner.solver.problem import Problem

CELL_M = 0.01       # column width along the master's line of sight
REST_CELL_M = 0.1   # the rest's cells: this wide and REST_ROW_M high
REST_ROW_M = 0.25
COARSE_CELL_M = 0.05  # a first, cheaper pass of each master interval
SUB_ROWS = 10       # rows of a strip's column for its weight bound
STRIP_M = 0.1       # strip width below the C8 cap (as a fraction of d_min at most STRIP_FRAC)
STRIP_FRAC = 0.2
NOT_TIGHT = 1e-3
CHAIN_STARTS, CHAIN_STARTS_M = 400, 100.0  # where the incumbent's chain may start
MAX_INTERVALS = 256  # master intervals evaluated per certificate (then the search takes over)


def applies(sc: Problem) -> bool:
    """The bound needs C4 (the spacing), C8 (the cap) and a master range above 0."""
    return sc.on("C4") and sc.on("C8") and sc.p.d_min > 0 and sc.r0_lo > 0


def relaxed(sc: Problem) -> tuple[Problem, int]:
    """(P) with every slave's station disk the largest of theirs (C9-C11 relaxed), and the
    slave with the loosest C8 cap: every slave given that slave's limits is a relaxation
    in which all are interchangeable."""
    big = max(sc.disk_r2[k] for k in sc.slaves)
    disk = tuple(big if i in sc.slaves else r2 for i, r2 in enumerate(sc.disk_r2))
    return (dataclasses.replace(sc, disk_r2=disk),
            max(sc.slaves, key=lambda k: slave_ranges.c8_cap(sc, k)))


def _cells(sc: Problem, k: int, r0a: float, r0b: float, ua, ub, ba, bb):
    """Upper bound on w / r0^2 of slave k over each cell [ua, ub] x [ba, bb] of (u, b) with
    r0 in [r0a, r0b]; -inf for a cell that holds no feasible point."""
    corners_t = [np.arctan2(b, u) for u in (ua, ub) for b in (ba, bb)]
    ta = np.maximum(sc.th0 + np.min(corners_t, axis=0), sc.th_lo)
    tb = np.minimum(sc.th0 + np.max(corners_t, axis=0), sc.th_hi)
    b_near = np.where((ba <= 0) & (bb >= 0), 0.0, np.minimum(np.abs(ba), np.abs(bb)))
    b_far = np.maximum(np.abs(ba), np.abs(bb))
    # theta in [ta, tb] caps |b| / u at the tangent of the angle furthest from theta_0
    tan_far = np.maximum(np.tan(np.abs(tb - sc.th0)), np.tan(np.abs(ta - sc.th0)))
    b_far = np.minimum(b_far, ub * tan_far)
    r_min, r_max = np.hypot(ua, b_near), np.hypot(ub, b_far)
    with np.errstate(invalid="ignore", divide="ignore"):
        lo, up, _, g_rg = slave_ranges.slave_box(sc, k, r0a, r0b, ta, tb)
        ok = (ta <= tb) & (lo <= up) & (up >= r_min) & (lo <= r_max)
        bn = np.minimum(b_far / r0a, slave_ranges.c8_cap(sc, k))
        w = rays.weight(sc, bn, g_rg, rays.snr_factor(sc, r0a, np.maximum(r_min, lo)))
    return np.where(ok & ~np.isnan(w), w, -np.inf)


def _grid_cells(sc: Problem, k: int, r0a: float, r0b: float, u_edges, b_edges):
    """_cells over the grid of u_edges x b_edges: (columns, rows)."""
    c, r = np.meshgrid(np.arange(len(u_edges) - 1), np.arange(len(b_edges) - 1), indexing="ij")
    c, r = c.ravel(), r.ravel()
    w = _cells(sc, k, r0a, r0b, u_edges[c], u_edges[c + 1], b_edges[r], b_edges[r + 1])
    return w.reshape(len(u_edges) - 1, len(b_edges) - 1)


def _strip_weights(sc: Problem, k: int, r0a: float, r0b: float, u_edges, b_lo, b_hi):
    """W(c) of a strip's columns: the largest bound over SUB_ROWS rows of each, so that
    every row's angles stay narrow (gamma_Rg and the theta limits are taken per row)."""
    return np.max(_grid_cells(sc, k, r0a, r0b, u_edges,
                              np.linspace(b_lo, b_hi, SUB_ROWS + 1)), axis=1)


def _strip_sums(w: np.ndarray, gap: int, m: int) -> np.ndarray:
    """F_0..F_m: the best sums of j column weights (w per column) at least `gap` columns
    apart; -inf where j columns do not fit."""
    f = np.full(m + 1, -np.inf)
    f[0] = 0.0
    best = w.copy()
    for j in range(1, m + 1):
        f[j] = float(np.max(best)) if len(best) else -np.inf
        if j == m or not np.isfinite(f[j]):
            break
        run = np.maximum.accumulate(best)             # best sum of j ending at or before c
        shifted = np.full_like(w, -np.inf)
        shifted[gap:] = run[:len(w) - gap]            # ... ending at least gap before c
        best = w + shifted
    return f


def group_weight_bound(sc: Problem, group: tuple[int, ...], r0a: float, r0b: float,
                       cell_m: float = CELL_M) -> float:
    """Upper bound on sum_{k in group} w_k / r0^2 over every feasible point with r0 in
    [r0a, r0b] (module docstring) with columns cell_m wide; -inf when the group provably has
    no feasible placement."""
    k, m, d = group[0], len(group), sc.p.d_min
    cap_b = slave_ranges.c8_cap(sc, k) * r0b
    delta = min(STRIP_M, STRIP_FRAC * d, cap_b)
    lo_all, up_all, _, _ = slave_ranges.slave_box(sc, k, r0a, r0b, np.array([sc.th_lo]),
                                                  np.array([sc.th_hi]))
    if not lo_all[0] <= up_all[0] or not math.isfinite(up_all[0]):
        return -math.inf if lo_all[0] > up_all[0] else math.inf
    u_lo = lo_all[0] * math.cos(max(abs(sc.th_lo - sc.th0), abs(sc.th_hi - sc.th0)))
    edges = np.arange(u_lo, up_all[0] + cell_m, cell_m)
    gap = math.ceil(math.sqrt(d * d - delta * delta) / cell_m) - 1
    sums = []
    for lo_b, far in ((cap_b - delta, sc.th_hi - sc.th0), (-cap_b, sc.th0 - sc.th_lo)):
        # the strip lies beyond u = (cap_b - delta) / tan(the side's widest look angle)
        start = (cap_b - delta) / math.tan(far) if far > 0 else math.inf
        cols = edges[max(0, np.searchsorted(edges, start) - 1):]
        w = (_strip_weights(sc, k, r0a, r0b, cols, lo_b, lo_b + delta) if len(cols) > 1
             else np.empty(0))
        sums.append(_strip_sums(w, gap, m))
    cols = np.arange(u_lo, up_all[0] + REST_CELL_M, REST_CELL_M)
    rows = np.linspace(delta - cap_b, cap_b - delta,
                       max(2, math.ceil(2 * cap_b / REST_ROW_M)) + 1)
    rest = _grid_cells(sc, k, r0a, r0b, cols, rows)
    w_rest = float(np.max(rest)) if len(rest) else -math.inf
    best = -math.inf
    for m1 in range(m + 1):
        for m2 in range(m + 1 - m1):
            m3 = m - m1 - m2
            total = sums[0][m1] + sums[1][m2] + (m3 * w_rest if m3 else 0.0)
            best = max(best, total)
    return best


def interval_bound(sc: Problem, r0a: float, r0b: float, cell_m: float = CELL_M) -> float:
    """Lower bound on the objective over every feasible point with r0 in [r0a, r0b] (+inf:
    none there), with columns cell_m wide: the group bound of the relaxation (`relaxed`)."""
    loose, k = relaxed(sc)
    total = group_weight_bound(loose, (k,) * len(sc.slaves), r0a, r0b, cell_m)
    if total == -math.inf:
        return math.inf
    return float(objective_from_normalised(sc, total)) if total < math.inf else 0.0


def certify(sc: Problem, value: float, r0_best: float, rel_gap: float,
            deadline: float = math.inf) -> tuple[float, bool, int]:
    """(lower bound on the optimum, every master interval closed, intervals evaluated):
    bisection over r0, an interval closed when its bound is within rel_gap of `value` (a
    feasible objective at master range r0_best). When even the point interval at r0_best
    stays open, the relaxation is not tight there (a slave's own disk or rung binds, or the
    optimum is no chain) and the bisection is not tried: by NOT_TIGHT, as a bound's columns
    fall differently on each interval (a few 1e-5 either way)."""
    if interval_bound(sc, r0_best, r0_best * (1.0 + 1e-12)) < value * (1.0 - NOT_TIGHT):
        return 0.0, False, 1
    open_iv = [(sc.r0_lo, sc.r0_hi, 0.0)]  # (r0a, r0b, a lower bound on it)
    closed_lb, evaluated = math.inf, 1
    while open_iv and evaluated < MAX_INTERVALS and time.monotonic() < deadline:
        nxt = []
        for a, b, _ in open_iv:
            lb = interval_bound(sc, a, b, COARSE_CELL_M)
            if lb < value * (1.0 - rel_gap):
                lb = max(lb, interval_bound(sc, a, b))
            evaluated += 1
            if lb >= value * (1.0 - rel_gap):
                closed_lb = min(closed_lb, lb)
            else:
                mid = 0.5 * (a + b)
                nxt += [(a, mid, lb), (mid, b, lb)]
        open_iv = nxt
    lower = min([closed_lb, value] + [lb for _, _, lb in open_iv])
    return lower, not open_iv, evaluated


def chain_incumbent(sc: Problem):
    """(value, point) of the chain itself: the master at its smallest range, the slaves on
    the C8 line (|b| = cap r0) d_min apart in u, on either side of theta_0, the first at the
    look-angle limit or further out by up to CHAIN_STARTS_M (a station disk or the master's
    hole may cut the line's start), their ranges from slave_sets.ranges_for at those angles
    (feasible by construction), the best then through local_refine; (inf, None) when no
    start gives a feasible point."""
    r0, d, k_count = sc.r0_lo, sc.p.d_min, len(sc.slaves)
    cap_b = min(slave_ranges.c8_cap(sc, k) for k in sc.slaves) * r0
    best: tuple[float, tuple | None] = (math.inf, None)
    for side, edge in ((1.0, sc.th_hi), (-1.0, sc.th_lo)):
        if side * (edge - sc.th0) <= 0:
            continue
        first = cap_b / math.tan(abs(edge - sc.th0)) + np.linspace(0.0, CHAIN_STARTS_M,
                                                                   CHAIN_STARTS)
        th = sc.th0 + side * np.arctan2(cap_b, first[:, None] + d * np.arange(k_count))
        f, ranges = slave_sets.ranges_for(sc, np.full(len(first), r0), th)
        i = int(np.argmin(f))
        if np.isfinite(f[i]) and f[i] < best[0]:
            best = (float(f[i]), (r0, tuple(map(float, th[i])), tuple(map(float, ranges[i]))))
    if best[1] is None:
        return best
    value, point, _ = local_refine.refine(sc, best[1], best[0])
    return value, point
