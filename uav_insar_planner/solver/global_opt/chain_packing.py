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
from collections.abc import Callable

import numpy as np

from uav_insar_planner.solver import rays
from uav_insar_planner.solver.global_opt import local_refine, slave_ranges, slave_sets
from uav_insar_planner.solver.global_opt.kernel import objective_from_normalised
from uav_insar_planner.solver.problem import Problem

CELL_M = 0.01       # column width along the master's line of sight
REST_CELL_M = 0.1   # the rest's cells: this wide and REST_ROW_M high
REST_ROW_M = 0.25
REST_COARSEN = 4  # the rest first on cells this many times larger each way
REST_BATCH = 16  # coarse cells of the rest cut into fine ones at a time, heaviest first
COARSE_CELL_M = 0.05  # a first, cheaper pass of each master interval
SUB_ROWS = 10       # rows of a strip's column for its weight bound
STRIP_M = 0.1       # strip width below the C8 cap (as a fraction of d_min at most STRIP_FRAC)
STRIP_FRAC = 0.2
NOT_TIGHT = 1e-3
CHAIN_STARTS, CHAIN_STARTS_M = 400, 100.0  # where the incumbent's chain may start
MAX_INTERVALS = 256  # master intervals evaluated per certificate (then the search takes over)
# certify: fine columns only within FINE_WITHIN of closing; an interval holding the
# incumbent's r0 is cut NEAR_CUT of its width either side of it.
FINE_WITHIN = 2e-4
# The fine columns: those of the heaviest REFINE_SPANS chain lengths of coarse columns.
REFINE_SPANS = 2
NEAR_CUT = 0.125


def applies(sc: Problem) -> bool:
    """The bound needs C4 (the spacing), C8 (the cap), a master range above 0 and a
    non-empty domain (else the search proves infeasibility at once)."""
    return (sc.on("C4") and sc.on("C8") and sc.p.d_min > 0 and 0 < sc.r0_lo <= sc.r0_hi
            and sc.th_lo <= sc.th_hi)


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


def _strip_weights(sc: Problem, k: int, r0a: float, r0b: float, ua, ub, b_lo, b_hi):
    """W(c) of a strip's columns [ua, ub]: the largest bound over SUB_ROWS rows of each, so
    that every row's angles stay narrow (gamma_Rg and the theta limits are taken per row)."""
    b_edges = np.linspace(b_lo, b_hi, SUB_ROWS + 1)
    c, r = np.meshgrid(np.arange(len(ua)), np.arange(SUB_ROWS), indexing="ij")
    c, r = c.ravel(), r.ravel()
    w = _cells(sc, k, r0a, r0b, ua[c], ub[c], b_edges[r], b_edges[r + 1])
    return np.max(w.reshape(len(ua), SUB_ROWS), axis=1)


def _refined_strip(sc: Problem, k: int, r0a: float, r0b: float, edges, w, keep: int,
                   cell_m: float, b_lo: float, b_hi: float):
    """(W, widest column) on columns about cell_m wide: the `keep` heaviest columns of
    `edges` (weights w) each cut into columns of their own, every other fine column bounded
    by its coarse column's weight (a valid bound: the coarse cell contains it)."""
    n_sub = max(1, round((edges[1] - edges[0]) / cell_m)) if len(edges) > 1 else 1
    frac = np.arange(n_sub + 1) / n_sub
    fine = edges[:-1, None] + (edges[1:] - edges[:-1])[:, None] * frac  # (columns, n_sub + 1)
    out = np.repeat(w[:, None], n_sub, axis=1)
    pick = np.argsort(w)[::-1][:keep]
    pick = pick[np.isfinite(w[pick])]
    if len(pick):
        ua, ub = fine[pick, :-1].ravel(), fine[pick, 1:].ravel()
        w_fine = _strip_weights(sc, k, r0a, r0b, ua, ub, b_lo, b_hi).reshape(len(pick), n_sub)
        out[pick] = np.minimum(w_fine, w[pick, None])
    return out.ravel(), float(np.max(fine[:, 1:] - fine[:, :-1])) if len(fine) else cell_m


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
        if gap < len(w):  # else no second column fits after any first
            shifted[gap:] = run[:len(w) - gap]        # ... ending at least gap before c
        best = w + shifted
    return f


def group_weight_bound(sc: Problem, group: tuple[int, ...], r0a: float, r0b: float,
                       cell_m: float = CELL_M,
                       refine_if: Callable[[float], bool] | None = None) -> float:
    """Upper bound on sum_{k in group} w_k / r0^2 over every feasible point with r0 in
    [r0a, r0b] (module docstring) with columns cell_m wide; -inf when the group provably has
    no feasible placement.

    Columns finer than COARSE_CELL_M: the strips are bounded on COARSE_CELL_M columns first,
    and then (unless refine_if says no, given that total) the heaviest REFINE_SPANS chain
    lengths of coarse columns per strip are cut to cell_m (the chain sits in the heaviest)."""
    k, m, d = group[0], len(group), sc.p.d_min
    cap_b = slave_ranges.c8_cap(sc, k) * r0b
    delta = min(STRIP_M, STRIP_FRAC * d, cap_b)
    lo_all, up_all, _, _ = slave_ranges.slave_box(sc, k, r0a, r0b, np.array([sc.th_lo]),
                                                  np.array([sc.th_hi]))
    if not lo_all[0] <= up_all[0] or not math.isfinite(up_all[0]):
        return -math.inf if lo_all[0] > up_all[0] else math.inf
    u_lo = lo_all[0] * math.cos(max(abs(sc.th_lo - sc.th0), abs(sc.th_hi - sc.th0)))
    coarse = max(cell_m, COARSE_CELL_M)
    edges = np.arange(u_lo, up_all[0] + coarse, coarse)
    d_strip = math.sqrt(d * d - delta * delta)
    strips = []
    for lo_b, far in ((cap_b - delta, sc.th_hi - sc.th0), (-cap_b, sc.th0 - sc.th_lo)):
        # the strip lies beyond u = (cap_b - delta) / tan(the side's widest look angle)
        start = (cap_b - delta) / math.tan(far) if far > 0 else math.inf
        cols = edges[max(0, np.searchsorted(edges, start) - 1):]
        w = (_strip_weights(sc, k, r0a, r0b, cols[:-1], cols[1:], lo_b, lo_b + delta)
             if len(cols) > 1 else np.empty(0))
        strips.append((cols, w, lo_b))
    sums = [_strip_sums(w, math.ceil(d_strip / coarse) - 1, m) for _, w, _ in strips]
    rest = _rest_cells(sc, k, r0a, r0b, u_lo, up_all[0], cap_b - delta)
    w_rest = float(np.max(rest[2])) if rest[2].size else -math.inf
    best, uses_rest = _combine(sums, w_rest, m)
    if uses_rest:  # the coarse cells of the rest count: bound them on the fine ones
        w_rest = _refined_rest(sc, k, r0a, r0b, *rest)
        best, _ = _combine(sums, w_rest, m)
    if cell_m >= coarse or (refine_if is not None and not refine_if(best)):
        return best
    keep = REFINE_SPANS * m * math.ceil(d_strip / coarse)
    sums = []
    for cols, w, lo_b in strips:
        if len(w):
            w, width = _refined_strip(sc, k, r0a, r0b, cols, w, keep, cell_m, lo_b, lo_b + delta)
            sums.append(_strip_sums(w, math.ceil(d_strip / width) - 1, m))
        else:
            sums.append(_strip_sums(w, 1, m))
    return min(best, _combine(sums, w_rest, m)[0])


def _rest_cells(sc: Problem, k: int, r0a: float, r0b: float, u_lo: float, u_hi: float,
                b_top: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(column edges, row edges, cell bounds (columns, rows)) of the rest, |b| <= b_top, on
    cells REST_COARSEN times REST_CELL_M x REST_ROW_M: their largest bound is a W_rest."""
    cols = np.arange(u_lo, u_hi + REST_COARSEN * REST_CELL_M, REST_COARSEN * REST_CELL_M)
    rows = np.linspace(-b_top, b_top,
                       max(2, math.ceil(2 * b_top / (REST_COARSEN * REST_ROW_M))) + 1)
    return cols, rows, _grid_cells(sc, k, r0a, r0b, cols, rows)


def _refined_rest(sc: Problem, k: int, r0a: float, r0b: float, cols: np.ndarray,
                  rows: np.ndarray, coarse: np.ndarray) -> float:
    """W_rest on finer cells: the coarse cells of _rest_cells cut REST_COARSEN x REST_COARSEN
    each, heaviest first, REST_BATCH at a time, until no coarse cell left whole bounds more
    than the largest fine one. Every point of the rest is then in a fine cell or in a whole
    coarse cell, each bounded, so the largest of those bounds is a W_rest (the whole coarse
    cells left are below it)."""
    flat = coarse.ravel()
    order = np.argsort(flat)[::-1]
    order = order[flat[order] > -np.inf]  # empty cells hold no point of the rest
    frac = np.arange(REST_COARSEN + 1) / REST_COARSEN
    fc, fr = np.meshgrid(np.arange(REST_COARSEN), np.arange(REST_COARSEN), indexing="ij")
    fc, fr = fc.ravel(), fr.ravel()  # each fine cell's column and row within its coarse one
    best = -math.inf
    for i in range(0, len(order), REST_BATCH):
        if flat[order[i]] <= best:
            return best
        c, r = np.unravel_index(order[i:i + REST_BATCH], coarse.shape)
        # each coarse cell's own edges, interpolated: the fine cells tile it exactly
        u = cols[c, None] + (cols[c + 1] - cols[c])[:, None] * frac
        b = rows[r, None] + (rows[r + 1] - rows[r])[:, None] * frac
        u[:, -1], b[:, -1] = cols[c + 1], rows[r + 1]
        w = _cells(sc, k, r0a, r0b, u[:, fc].ravel(), u[:, fc + 1].ravel(), b[:, fr].ravel(),
                   b[:, fr + 1].ravel())
        best = max(best, float(np.max(w)))
    return best


def _combine(sums: list[np.ndarray], w_rest: float, m: int) -> tuple[float, bool]:
    """(max over m1 + m2 + m3 = m of F+_m1 + F-_m2 + m3 W_rest (module docstring), whether
    W_rest is in it: a maximiser has m3 > 0)."""
    best, uses_rest = -math.inf, False
    for m1 in range(m + 1):
        for m2 in range(m + 1 - m1):
            m3 = m - m1 - m2
            total = sums[0][m1] + sums[1][m2] + (m3 * w_rest if m3 else 0.0)
            if total > best or (total == best and m3):
                best, uses_rest = total, m3 > 0
    return best, uses_rest


def interval_bound(sc: Problem, r0a: float, r0b: float, cell_m: float = CELL_M,
                   close_at: float | None = None) -> float:
    """Lower bound on the objective over every feasible point with r0 in [r0a, r0b] (+inf:
    none there), with columns cell_m wide: the group bound of the relaxation (`relaxed`).
    close_at: the fine columns are spent only when the coarse bound is below close_at by at
    most FINE_WITHIN (see certify)."""
    loose, k = relaxed(sc)

    def objective(total: float) -> float:
        if total == -math.inf:
            return math.inf
        return float(objective_from_normalised(sc, total)) if total < math.inf else 0.0

    refine_if = None if close_at is None else (
        lambda total: close_at * (1.0 - FINE_WITHIN) <= objective(total) < close_at)
    return objective(group_weight_bound(loose, (k,) * len(sc.slaves), r0a, r0b, cell_m,
                                        refine_if))


def certify(sc: Problem, value: float, r0_best: float, rel_gap: float,
            deadline: float = math.inf) -> tuple[float, bool, int]:
    """(lower bound on the optimum, every master interval closed, intervals evaluated):
    a search over r0, an interval closed when its bound is within rel_gap of `value` (a
    feasible objective at master range r0_best). When even the point interval at r0_best
    stays open, the relaxation is not tight there (a slave's own disk or rung binds, or the
    optimum is no chain) and the search is not tried: by NOT_TIGHT, as a bound's columns
    fall differently on each interval (a few 1e-5 either way).

    Each interval gets the coarse columns first and the fine ones only when the coarse bound
    is within FINE_WITHIN of closing (the fine columns gain some 1e-5; far from closing the
    interval has to be cut anyway). An interval holding r0_best is cut NEAR_CUT of its width
    either side of r0_best (the bound is loosest there and needs the narrowest interval), any
    other one is halved."""
    if interval_bound(sc, r0_best, r0_best * (1.0 + 1e-12),
                      close_at=value * (1.0 - NOT_TIGHT)) < (
            value * (1.0 - NOT_TIGHT)):
        return 0.0, False, 1
    open_iv = [(sc.r0_lo, sc.r0_hi, 0.0)]  # (r0a, r0b, a lower bound on it)
    closed_lb, evaluated = math.inf, 1
    close_at = value * (1.0 - rel_gap)
    while open_iv and evaluated < MAX_INTERVALS and time.monotonic() < deadline:
        nxt = []
        for a, b, _ in open_iv:
            lb = interval_bound(sc, a, b, close_at=close_at)
            evaluated += 1
            if lb >= close_at:
                closed_lb = min(closed_lb, lb)
            else:
                nxt += [(x, y, lb) for x, y in _cut(a, b, r0_best)]
        open_iv = nxt
    lower = min([closed_lb, value] + [lb for _, _, lb in open_iv])
    return lower, not open_iv, evaluated


def _cut(a: float, b: float, r0_best: float) -> list[tuple[float, float]]:
    """The pieces of an open master interval (see certify)."""
    if not a <= r0_best <= b:
        mid = 0.5 * (a + b)
        return [(a, mid), (mid, b)]
    near = NEAR_CUT * (b - a)
    cuts = sorted({a, max(a, r0_best - near), min(b, r0_best + near), b})
    return [(x, y) for x, y in zip(cuts[:-1], cuts[1:], strict=True) if y > x]


def chain_incumbent(sc: Problem, starts: int = CHAIN_STARTS):
    """(value, point, landed) of the chain itself: the master at its smallest range, the
    slaves on the C8 line (|b| = cap r0) d_min apart in u, on either side of theta_0, the
    first at the look-angle limit or further out by up to CHAIN_STARTS_M (a station disk or
    the master's hole may cut the line's start; `starts` of them), their ranges from
    slave_sets.ranges_for at those angles (feasible by construction), the best then through
    local_refine unless it already meets the KKT conditions (landed: a local optimum, or
    SLSQP ended on the ray model's feasible set); (inf, None, False) when no start gives a
    feasible point."""
    r0, d, k_count = sc.r0_lo, sc.p.d_min, len(sc.slaves)
    cap_b = min(slave_ranges.c8_cap(sc, k) for k in sc.slaves) * r0
    sides = []  # both sides' starts in one call, the upper side first (it wins ties)
    for side, edge in ((1.0, sc.th_hi), (-1.0, sc.th_lo)):
        if side * (edge - sc.th0) > 0:
            first = cap_b / math.tan(abs(edge - sc.th0)) + np.linspace(0.0, CHAIN_STARTS_M,
                                                                       starts)
            sides.append(sc.th0 + side * np.arctan2(cap_b, first[:, None]
                                                    + d * np.arange(k_count)))
    if not sides:
        return math.inf, None, False
    th = np.concatenate(sides)
    f, ranges = slave_sets.ranges_for(sc, np.full(len(th), r0), th)
    i = int(np.argmin(f))
    if not np.isfinite(f[i]):
        return math.inf, None, False
    value, point = float(f[i]), (r0, tuple(map(float, th[i])), tuple(map(float, ranges[i])))
    if local_refine.at_kkt(sc, point):  # already a local optimum (Table I's chain is)
        return value, point, True
    return local_refine.refine(sc, point, value)
