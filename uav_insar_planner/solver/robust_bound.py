"""A certified lower bound of the robust problem (P_e): a branch and bound over the master's range.

Frame. Target p_t = (x_t, 0), u = (-sin theta_0, cos theta_0) the master's line of sight (from
the target), n = (cos theta_0, sin theta_0) its normal; a point is p_t + a u + c n. C2 puts the
planned master at (r_0, 0), so b_perp,k = |c_k| (eq. 3 with the normal n), r_k = |(a_k, c_k)|
and theta_k = theta_0 - atan2(c_k, a_k); c_k's sign is the slave's side of the line of sight.

Why every robust-feasible formation q with r_0 in [r_1, r_2] has a worst case >= LB(r_1, r_2):

1. Necessary conditions. Robust feasibility holds at every point of the disks, so at chosen
   ones: C1 at z_k -+ e, C3 and C7 at the tangents theta_k -+ asin(e / r_k) (C7's interval
   of look angles, gamma_Rg unimodal), C4 with the master at distance - 2e, C6 at ranges
   r_0 + e, r_k + e, C5 at the slave moved e towards the target (swath Theta (r_k - e) r_k /
   z_k), C10 at rho_k + e from the station, and C8 with the slave e outwards along n and the
   master on its rim at the angle phi* = atan2(1, -c) from its line of sight (c =
   lambda sin(theta_0) / h_amb,k^min): |c_k| <= c (r_0 + eps) - e (1 + sqrt(1 + c^2)),
   eps = e^2 / (2 (r_0 - e)) bounding |r_0 + e e^(i phi)| - r_0 - e cos phi (`_cap`). Over a
   box of slave positions and the interval each is checked where it is easiest to meet; a box
   that fails one holds no robust-feasible slave (`_possible`). The master's own C1, C5 and
   C10 give the range of r_0 (`frame`).
2. Worst case at chosen positions. sigma_h_worst^-2 = min over master positions of
   sum_k min over D_k of w_k <= sum_k w_k at the master moved e at angle phi_m (a rim point)
   and slave k moved e at angle psi (a rim point), for every phi_m and psi. Over a box and the
   interval, w_k there is at most its value with b_perp the largest |c - e sin phi_m| the
   moved box reaches (c clipped to the C8 cap), r_0 the moved master's least range, and
   gamma_Rg, gamma_SNR at their largest over the moved box (`_upper`); the least over the
   psi tried is kept.
3. Slaves apart. Dropping C4 between slaves only enlarges the set, so each slave's largest w
   over its boxes, G_k(phi_m, side), bounds its term; for a side pattern s (each slave's sign of
   c_k), sigma_h_worst^-2 <= min_phi_m sum_k G_k(phi_m, s_k). LB(I) = (max over patterns of that
   min)^(-1/2); no robust-feasible slave on one side leaves that side's patterns out.

A box is split while its bound may exceed the largest w found at box centres (`INNER_TOL`) and
it is wider than `MIN_BOX_M` (a choice of effort only: every box's bound holds). Every master
interval whose LB is below the target (the plan's certified worst case less the tolerance) is
split in two, all in one batch (the least first, within `MAX_INTERVALS`), and a half's LB is
the larger of its own and its parent's (it bounds a subset). A half starts from its parent's
boxes: they cover every slave the half allows, and their bounds hold over the half too, so a
box far below the largest keeps its parent's bound (`CARRY`). All intervals of a batch are
bounded together as one array of boxes. The answer is the least LB over the intervals left,
which cover the master's range: no robust-feasible formation does better.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.schemes import slave_uavs
from uav_insar_planner.solver.power import station_radius_sq
from uav_insar_planner.solver.problem import c7_sines
from uav_insar_planner.swarm import MASTER

# Master rim angles phi_m from its line of sight (0: away from the target, +-pi/2 along +-n).
MASTER_ANGLES = np.linspace(-math.pi / 2, math.pi / 2, 9)
# Slave rim angles tried, offsets from the direction towards the master's line of sight (any
# rim point is sound; at Table I five offsets in -+pi/6 gave the same bounds as this one).
SLAVE_OFFSETS = np.zeros(1)
INNER_TOL = 1e-2
MIN_BOX_M = 0.02
# An inherited box this far below its interval's largest bound is carried, not bounded again.
CARRY = 0.03
INNER_ROUNDS = 10
FIRST_INTERVALS = 8
MAX_INTERVALS = 100
MAX_PATTERN_SLAVES = 9  # 2^9 side patterns


@dataclass(frozen=True)
class Frame:
    """The scenario in the (a, c) frame: the look angles C3 and C7 leave, the station's (a, c),
    each UAV's station reach (C10's radius less e), each slave's C8 slope, r_0's range."""

    p: Params
    scheme: str
    slaves: tuple[int, ...]
    look: tuple[float, float]
    station: tuple[float, float]
    reach: dict[int, float]
    slope: dict[int, float]
    r0_range: tuple[float, float]


def to_xz(p: Params, a, c) -> tuple[np.ndarray, np.ndarray]:
    """(x, z) of the point p_t + a u + c n."""
    s0, c0 = math.sin(p.theta0), math.cos(p.theta0)
    return p.x_t - np.multiply(a, s0) + np.multiply(c, c0), np.multiply(a, c0) + np.multiply(c, s0)


def frame(p: Params, scheme: str) -> Frame | None:
    """The frame, or None where it does not apply (a fixed master off its C2 line, no C7
    interval); an empty r0_range when the master's own families leave no range."""
    e, s0, c0 = p.nav_error_m, math.sin(p.theta0), math.cos(p.theta0)
    sines = c7_sines(p)
    if sines is None:
        return None
    look = (max(p.theta_min, math.asin(min(sines[0], 1.0))),
            min(p.theta_max, math.asin(min(sines[1], 1.0))))
    gx, gz = p.ground_station[0] - p.x_t, p.ground_station[2]
    station = (-s0 * gx + c0 * gz, c0 * gx + s0 * gz)
    uavs = (MASTER, *slave_uavs(scheme, p.num_uavs))
    reach = {}
    for k in uavs:
        r2 = station_radius_sq(p, k, scheme)
        reach[k] = math.sqrt(r2) if r2 >= 0 else -math.inf
    slope = {k: p.wavelength * s0 / model.h_amb_min_of(p, k) for k in uavs[1:]}
    lo = max((p.z_min + e) / c0, p.swath_min * c0 / p.beamwidth + e)
    hi = (p.z_max - e) / c0
    if reach[MASTER] < abs(station[1]):
        return Frame(p, scheme, uavs[1:], look, station, reach, slope, (1.0, 0.0))
    if reach[MASTER] < math.inf:
        half = math.sqrt(reach[MASTER] ** 2 - station[1] ** 2)
        lo, hi = max(lo, station[0] - half), min(hi, station[0] + half)
    if scheme == "fixed-master":
        xm, zm = p.master_fixed
        a, c = -s0 * (xm - p.x_t) + c0 * zm, c0 * (xm - p.x_t) + s0 * zm
        if abs(c) > 1e-9 * max(a, 1.0):
            return None
        lo, hi = (a, a) if lo <= a <= hi else (1.0, 0.0)
    return Frame(p, scheme, uavs[1:], look, station, reach, slope, (lo, hi))


def _cap(fr: Frame, k: int, r0) -> np.ndarray:
    """The largest |c_k| C8 allows a robust-feasible slave at master range r_0 (step 1)."""
    e, s = fr.p.nav_error_m, fr.slope[k]
    r0 = np.asarray(r0, dtype=float)
    return s * (r0 + e * e / (2.0 * np.maximum(r0 - e, 1e-9))) - e * (1.0 + math.sqrt(1 + s * s))


def _corners(a1, a2, c1, c2):
    """Look-angle offsets atan2(c, a), ranges' extremes over boxes (a1 >= 0): (lo, hi) each."""
    ang = np.stack([np.arctan2(c, a) for a in (a1, a2) for c in (c1, c2)])
    cabs_lo = np.where((c1 <= 0) & (c2 >= 0), 0.0, np.minimum(np.abs(c1), np.abs(c2)))
    r_lo = np.hypot(np.maximum(a1, 0.0), cabs_lo)
    r_hi = np.hypot(np.maximum(np.abs(a1), np.abs(a2)), np.maximum(np.abs(c1), np.abs(c2)))
    return ang.min(axis=0), ang.max(axis=0), r_lo, r_hi, cabs_lo


def _possible(fr: Frame, k: int, box: np.ndarray, r1, r2) -> np.ndarray:
    """False where no point of the boxes (m, 4) = (a1, a2, c1, c2) is a robust-feasible slave k
    for any r_0 in [r1, r2] (step 1)."""
    p, e = fr.p, fr.p.nav_error_m
    a1, a2, c1, c2 = box.T
    s0, c0 = math.sin(p.theta0), math.cos(p.theta0)
    z_lo = np.minimum(a1, a2) * c0 + np.minimum(c1 * s0, c2 * s0)
    z_hi = a2 * c0 + c2 * s0
    off_lo, off_hi, r_lo, r_hi, cabs_lo = _corners(a1, a2, c1, c2)
    spread = np.arcsin(np.minimum(e / np.maximum(r_hi, 1e-9), 1.0))
    ok = (z_hi - e >= p.z_min) & (z_lo + e <= p.z_max)
    ok &= (p.theta0 - off_lo - spread >= fr.look[0]) & (p.theta0 - off_hi + spread <= fr.look[1])
    far = np.hypot(np.maximum(a2 - r1, r2 - a1), np.maximum(np.abs(c1), np.abs(c2)))
    ok &= far >= p.d_min + 2 * e
    ok &= model.coherence_snr_at_ranges(r1 + e, r_lo + e, model.gamma_m(p)) >= p.coherence_snr_min
    ok &= p.beamwidth * np.maximum(r_hi - e, 0.0) * r_hi >= p.swath_min * z_lo
    ok &= cabs_lo <= _cap(fr, k, r2)
    ga, gc = fr.station
    da = np.maximum.reduce([np.zeros_like(a1), a1 - ga, ga - a2])
    dc = np.maximum.reduce([np.zeros_like(c1), c1 - gc, gc - c2])
    return ok & (np.hypot(da, dc) <= fr.reach[k])


def _upper(fr: Frame, k: int, box: np.ndarray, r1, r2, side: int) -> np.ndarray:
    """(m, len(MASTER_ANGLES)): an upper bound of min over the slave rim angles tried of w_k,
    the master moved at each phi_m, over the boxes (on `side`) and r_0 in [r1, r2] (step 2);
    r1, r2 scalars or one per box."""
    from uav_insar_planner.solver.worst_case import gamma_rg, pair_weight

    p, e = fr.p, fr.p.nav_error_m
    r1, r2 = (np.broadcast_to(np.asarray(r, dtype=float), (len(box),)) for r in (r1, r2))
    cap, s = _cap(fr, k, r2), fr.slope[k]
    phi = MASTER_ANGLES[None, :, None]
    off = SLAVE_OFFSETS[None, None, :]
    psi = -side * math.pi / 2 + off
    d1, d2 = (np.hypot(r[:, None, None] + e * np.cos(phi), e * np.sin(phi)) for r in (r1, r2))
    a1, a2 = (box[:, i, None, None] + e * np.cos(psi) for i in (0, 1))
    c1, c2 = (np.clip(box[:, i], -cap, cap)[:, None, None] + e * np.sin(psi) for i in (2, 3))
    # b_perp / r_0 with the side's c = side c_k >= 0: the box's near edge, else its far edge
    # or the C8 cap, whose ratio to r_0 is bounded along [r1, r2] by its slope (docstring)
    near_c, far_c = (np.minimum(side * box[:, 2], side * box[:, 3]).clip(0.0, cap),
                     np.maximum(side * box[:, 2], side * box[:, 3]).clip(0.0, cap))
    shift = -e * np.cos(off) - side * e * np.sin(phi)
    slope = (s * (1.0 - e * e / (2.0 * (r1 - e) ** 2)))[:, None, None]
    cap_rate = _cap_ratio(cap[:, None, None] + shift, d2, slope, (r2 - r1)[:, None, None])
    ratio = np.maximum(np.abs(near_c[:, None, None] + shift) / d1,
                       np.minimum((far_c[:, None, None] + shift) / d1, cap_rate))
    off_lo, off_hi, r_lo, _, _ = _corners(a1, a2, c1, c2)
    nearest = np.where(off_lo > 0, off_lo, np.where(off_hi < 0, off_hi, 0.0))
    g = (gamma_rg(p, p.theta0 - nearest) * p.coherence_other
         * model.coherence_snr_at_ranges(d1, r_lo, model.gamma_m(p)))
    return pair_weight(p, np.maximum(ratio, 0.0), 1.0, g).min(axis=2)


def _cap_ratio(top, d2, slope, width):
    """sup over r_0 in [r2 - width, r2] of N(r_0) / D(r_0) with N(r2) = top, N' >= slope and
    D(r2) = d2, D' <= 1: N / D <= (top - slope t) / (d2 - t), t = r2 - r_0, a ratio of linear
    forms in t, so at most its larger end value (0 when both are negative)."""
    return np.maximum(np.maximum(top / d2, (top - slope * width) / (d2 - width)), 0.0)


def _group_max(out: np.ndarray, owner: np.ndarray, values: np.ndarray) -> None:
    """out[j] = max(out[j], every row of `values` whose owner is j), in place."""
    if len(owner):
        order = np.argsort(owner, kind="stable")
        o = owner[order]
        starts = np.flatnonzero(np.r_[True, o[1:] != o[:-1]])
        j = o[starts]
        out[j] = np.maximum(out[j], np.maximum.reduceat(values[order], starts, axis=0))


def _first_boxes(fr: Frame, k: int, side: int, r1: np.ndarray, r2: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Slave k's starting boxes on `side` for each interval (with their owners): a along the
    line of sight up to the farthest C6 allows, c between 0 and the C8 cap (step 1)."""
    e = fr.p.nav_error_m
    cap = _cap(fr, k, r2)
    reach = np.asarray(model.slave_range_max(fr.p, r1 + e), dtype=float) - e
    live = np.flatnonzero((cap >= 0) & (reach > 0))
    t = np.linspace(0.0, 1.0, 9)
    a_lo, a_hi = reach[live, None] * t[None, :-1], reach[live, None] * t[None, 1:]
    c_lo, c_hi = np.minimum(0.0, side * cap[live]), np.maximum(0.0, side * cap[live])
    boxes = np.stack([a_lo.ravel(), a_hi.ravel(), np.repeat(c_lo, 8), np.repeat(c_hi, 8)],
                     axis=1)
    return boxes, np.repeat(live, 8)


def _slave_max(fr: Frame, k: int, side: int, r1: np.ndarray, r2: np.ndarray,
               start: tuple[np.ndarray, ...] | None = None
               ) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
    """(G_k(phi_m, side) for each interval [r1[j], r2[j]], the boxes left): the largest w_k
    bound over slave k's boxes on that side (step 3), -inf for every phi_m where none is left.
    Boxes come as (boxes (m, 4) = (a1, a2, c1, c2), the interval owning each, a bound of w_k
    over each for its owner (m, len(MASTER_ANGLES))). `start`: a wider interval's boxes left,
    owners re-indexed: they cover every slave the narrower interval allows, and their bounds
    hold for it too (a subset of r_0), so a box whose bound is below (1 - CARRY) of its
    interval's largest at every phi_m is carried with it, not bounded again. All intervals are
    bounded together, one array of boxes, so the cost is arithmetic, not calls."""
    n, size = len(r1), len(MASTER_ANGLES)
    cap = _cap(fr, k, r2)
    reach = np.asarray(model.slave_range_max(fr.p, r1 + fr.p.nav_error_m)) - fr.p.nav_error_m
    if start is None:
        boxes, owner = _first_boxes(fr, k, side, r1, r2)
        prior = np.full((len(boxes), size), np.inf)
    else:
        boxes, owner, prior = start
    live = ((cap >= 0) & (reach > 0))[owner]
    boxes, owner, prior = boxes[live], owner[live], prior[live]
    best, g, top = np.full((n, size), -np.inf), np.full((n, size), -np.inf), np.full(
        (n, size), -np.inf)
    _group_max(top, owner, prior)
    carry = (prior < (1.0 - CARRY) * top[owner]).all(axis=1)
    _group_max(g, owner[carry], prior[carry])
    kept = [(boxes[carry], owner[carry], prior[carry])]
    boxes, owner = boxes[~carry], owner[~carry]
    for _ in range(INNER_ROUNDS):
        ok = _possible(fr, k, boxes, r1[owner], r2[owner])
        boxes, owner = boxes[ok], owner[ok]
        if not len(boxes):
            break
        up = _upper(fr, k, boxes, r1[owner], r2[owner], side)
        centre = np.repeat(0.5 * (boxes[:, ::2] + boxes[:, 1::2]), 2, axis=1)
        fine = np.flatnonzero(_possible(fr, k, centre, r1[owner], r2[owner]))
        _group_max(best, owner[fine], _upper(fr, k, centre[fine], r1[owner[fine]],
                                             r2[owner[fine]], side))
        small = (boxes[:, 1] - boxes[:, 0] < MIN_BOX_M) & (boxes[:, 3] - boxes[:, 2] < MIN_BOX_M)
        done = ~(up > best[owner] * (1 + INNER_TOL)).any(axis=1) | small
        _group_max(g, owner[done], up[done])
        kept.append((boxes[done], owner[done], up[done]))
        boxes, owner = _split(boxes[~done]), np.repeat(owner[~done], 2)
    if len(boxes):
        up = _upper(fr, k, boxes, r1[owner], r2[owner], side)
        _group_max(g, owner, up)
        kept.append((boxes, owner, up))
    left = tuple(np.concatenate(part) for part in zip(*kept, strict=True))
    return np.where(np.isfinite(g), np.maximum(g, best), -np.inf), left


def _split(boxes: np.ndarray) -> np.ndarray:
    """Each box halved along its longer side, the halves in order."""
    wide = (boxes[:, 1] - boxes[:, 0]) >= (boxes[:, 3] - boxes[:, 2])
    lo, hi = boxes.copy(), boxes.copy()
    mid_a, mid_c = 0.5 * (boxes[:, 0] + boxes[:, 1]), 0.5 * (boxes[:, 2] + boxes[:, 3])
    lo[wide, 1], hi[wide, 0] = mid_a[wide], mid_a[wide]
    lo[~wide, 3], hi[~wide, 2] = mid_c[~wide], mid_c[~wide]
    return np.stack([lo, hi], axis=1).reshape(-1, 4)


def interval_bounds(fr: Frame, r1: np.ndarray, r2: np.ndarray, boxes: dict | None = None
                    ) -> tuple[np.ndarray, dict]:
    """LB(r1[j], r2[j]) for each interval (step 3), +inf where no robust-feasible formation
    has r_0 in it, and each (slave, side)'s boxes left with their owners (`boxes`: wider
    intervals' left boxes, owners re-indexed to these intervals, to start from)."""
    g, left = {}, {}
    for key in ((k, s) for k in fr.slaves for s in (-1, 1)):
        g[key], left[key] = _slave_max(fr, *key, r1, r2, None if boxes is None else boxes[key])
    n = len(r1)
    most = np.zeros(n) if fr.slaves else np.full(n, -np.inf)
    found = np.zeros(n, dtype=bool)
    for sides in itertools.product((-1, 1), repeat=len(fr.slaves)):
        total = np.zeros((n, len(MASTER_ANGLES))) + sum(
            g[k, s] for k, s in zip(fr.slaves, sides, strict=True))
        fin = np.isfinite(total).all(axis=1)
        most = np.where(fin, np.maximum(most, np.where(fin, total.min(axis=1), 0.0)), most)
        found |= fin
    with np.errstate(divide="ignore"):
        lb = np.where(found & (most > 0), 1.0 / np.sqrt(np.maximum(most, 1e-300)), np.inf)
    return lb, left


def _children(left: dict, want: np.ndarray, count: int) -> dict:
    """The split intervals' left boxes, given to both halves: owner j of want[j] -> j and
    j + len(want) (the halves' order in `lower_bound`)."""
    pos = np.full(count, -1)
    pos[want] = np.arange(len(want))
    out = {}
    for key, (b, o, u) in left.items():
        sel = pos[o] >= 0
        bb, oo, uu = b[sel], pos[o[sel]], u[sel]
        out[key] = (np.concatenate([bb, bb]), np.concatenate([oo, oo + len(want)]),
                    np.concatenate([uu, uu]))
    return out


def _merge(left: dict, keep: np.ndarray, new: dict, offset: int) -> dict:
    """The kept intervals' boxes (owners renumbered in order) and the new ones' (after them)."""
    pos = np.cumsum(keep) - 1
    out = {}
    for key, (b, o, u) in left.items():
        sel = keep[o]
        nb, no, nu = new[key]
        out[key] = (np.concatenate([b[sel], nb]), np.concatenate([pos[o[sel]], no + offset]),
                    np.concatenate([u[sel], nu]))
    return out


def lower_bound(p: Params, scheme: str, target: float) -> float:
    """The certified lower bound of (P_e) (module docstring); NaN where the frame does not
    apply (fixed master off its line, too many slaves for the side patterns). Every interval
    whose bound is below `target` is split in one batch (the least first, within
    MAX_INTERVALS): each must be, for the least bound to reach the target."""
    fr = frame(p, scheme)
    if fr is None or len(fr.slaves) > MAX_PATTERN_SLAVES:
        return math.nan
    lo, hi = fr.r0_range
    if lo > hi:
        return math.inf
    edges = np.linspace(lo, hi, FIRST_INTERVALS + 1) if hi > lo else np.array([lo, hi])
    r1, r2 = edges[:-1].copy(), edges[1:].copy()
    bounds, left = interval_bounds(fr, r1, r2)
    count = len(r1)
    while count < MAX_INTERVALS:
        want = np.flatnonzero((bounds < target) & (r2 - r1 > 1e-6))
        if not len(want):
            break
        want = want[np.argsort(bounds[want], kind="stable")][:max((MAX_INTERVALS - count) // 2, 1)]
        mid = 0.5 * (r1[want] + r2[want])
        c1, c2 = np.concatenate([r1[want], mid]), np.concatenate([mid, r2[want]])
        child, new = interval_bounds(fr, c1, c2, _children(left, want, len(r1)))
        child = np.maximum(child, np.tile(bounds[want], 2))
        keep = np.ones(len(r1), dtype=bool)
        keep[want] = False
        left = _merge(left, keep, new, int(keep.sum()))
        r1, r2 = np.concatenate([r1[keep], c1]), np.concatenate([r2[keep], c2])
        bounds = np.concatenate([bounds[keep], child])
        count += len(c1)
    return float(bounds.min())
