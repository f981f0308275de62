"""Each slave's look angles where its ray limits can hold at all, proven once per search.

Why. A box's bound (slave_ranges.slave_box) takes every range limit at its own most
favourable corner of the box, so the lower and the upper limit of a slave may come from
opposite ends of its angle interval. Where both fall with theta at similar slopes (the C5
floor S_min cos(theta) / Theta_3dB and the station disk's far edge r_b(theta) of the
static-power scheme, whose slave sits on their crossing: 60 and 48 m/rad), a box beyond the
crossing by eps is proven empty only when its angle width is below about eps (60 - 48) /
(60 + 48), and until then its bound takes the slave at r_b of the box's far end: above the
optimum's range. The search then grinds a wedge of ever thinner boxes along the crossing,
times every cell of the other coordinates where the objective is near the optimum (Figure 3's
static-power point at h_amb_min 0.7 m: 99 299 of its 118 181 final boxes proven empty, 1.2e-5
rad wide in both angles, nearly all within 2e-3 rad of slave 1's crossing at 0.68519 rad and
at the smallest r0; 233 602 boxes in all).

What. The limits taken over the whole master interval [r0_lo, r0_hi] (slave_box with that
r0 interval: each limit at its most favourable r0 and angle, as for any box, so the result
holds for every r0 of every box) are a function of the angle alone. `feasible_angles` proves,
by that same interval test on a partition of the slave's angle domain refined only where the
test's answer changes, a union of closed intervals outside which the slave has no feasible
range for any r0. `clip_to_feasible` cuts a box's angle interval to the hull of its part
inside that union.

Proof that the box bound stays a lower bound. A dropped cell [a, b] has lo > up in slave_box's
interval test over r0 in [r0_lo, r0_hi] and theta in [a, b], so no point of (P) has this
slave's angle in it. Every feasible point of a box therefore lies in the box cut to the kept
intervals' hull, and box_lower_bound of the cut box (a lower bound over every feasible point
of *any* box) bounds it; an empty cut proves the box empty. The cut is applied inside the
bound only: the search's boxes keep covering the domain (warm.py carries them to the next
sweep point, where other limits hold).
"""
from __future__ import annotations

import numpy as np

from uav_insar_planner.solver.global_opt import slave_ranges
from uav_insar_planner.solver.problem import Problem

# First partition of the slaves' angle domain; then each undecided cell (not proven empty, an
# end of it without a feasible range) is cut in SUBCELLS until cells are MIN_WIDTH of the
# domain: the range limits move some 100 m/rad, so the cut box ends some 2e-7 m of range
# (0.2 rad domains) beyond the true edge. Three rounds of refinement reach it.
FIRST_CELLS = 64
SUBCELLS = 128
MIN_WIDTH = 1e-8
# From this round of the search on, the first round that proves at least CUT_SHARE of its
# boxes and at least CUT_MIN_EMPTY boxes empty switches the cut on (`once_grinding`; proving
# the angles costs about a millisecond): the coarse split's first rounds prove the bulk of
# the infeasible domain empty
# (Table I from its 128 root boxes: 15, 86, 116 and 24 of 128, 368, 464 and 240 boxes in
# rounds 1-4, none after), while a search grinding along a slave's feasibility edge proves
# many empty in most rounds (Figure 3's static-power points at h_amb_min 0.5-0.9 m: 38-88 %
# in round 4 or 5, 79 to 760 boxes; a warm start's last rounds, a few dozen boxes, may prove
# a quarter of them empty without grinding).
CUT_FROM_ROUND = 4
CUT_SHARE = 0.25
CUT_MIN_EMPTY = 64


def _empty(sc: Problem, ta: np.ndarray, tb: np.ndarray) -> np.ndarray:
    """slave_box's emptiness test of each slave (row j: sc.slaves[j]) over [ta, tb] x
    [r0_lo, r0_hi]."""
    r0a, r0b = np.full(ta.shape[1], sc.r0_lo), np.full(ta.shape[1], sc.r0_hi)
    lo, up, _, _ = slave_ranges.slave_box(sc, tuple(sc.slaves), r0a, r0b, ta, tb)
    return ~(lo <= up)


def feasible_angles(sc: Problem) -> list[np.ndarray]:
    """Per slave of sc.slaves, (m, 2) sorted disjoint closed angle intervals outside which it
    has no feasible range at any master range (module docstring); (0, 2) when it has none."""
    k_count, width = len(sc.slaves), sc.th_hi - sc.th_lo
    edges = np.linspace(sc.th_lo, sc.th_hi, FIRST_CELLS + 1)
    cells = [np.stack([edges[:-1], edges[1:]], axis=1)] * k_count
    kept: list[list[np.ndarray]] = [[] for _ in range(k_count)]
    steps = np.linspace(0.0, 1.0, SUBCELLS + 1)
    while any(len(c) for c in cells):
        n = max(len(c) for c in cells)
        pad = np.stack([np.concatenate([c, np.repeat(c[-1:] if len(c) else edges[None, :2],
                                                      n - len(c), axis=0)]) for c in cells])
        ta, tb = pad[:, :, 0], pad[:, :, 1]  # (K, n)
        empty, end_a, end_b = np.split(_empty(sc, np.concatenate([ta, ta, tb], axis=1),
                                              np.concatenate([tb, ta, tb], axis=1)), 3, axis=1)
        last = max(float(np.max(c[:, 1] - c[:, 0], initial=0.0)) for c in cells) <= (
            MIN_WIDTH * width)
        for j in range(k_count):
            m = len(cells[j])
            undecided = ~empty[j, :m] & (end_a[j, :m] | end_b[j, :m]) & (not last)
            kept[j].append(cells[j][~empty[j, :m] & ~undecided])
            cut = cells[j][undecided]
            grid = cut[:, :1] + (cut[:, 1:] - cut[:, :1]) * steps
            grid[:, -1] = cut[:, 1]
            cells[j] = np.stack([grid[:, :-1].ravel(), grid[:, 1:].ravel()], axis=1)
    return [_merged(np.concatenate(k)) for k in kept]


def _merged(cells: np.ndarray) -> np.ndarray:
    """Touching cells joined into intervals, sorted."""
    if not len(cells):
        return cells
    cells = cells[np.argsort(cells[:, 0])]
    starts = np.concatenate([[True], cells[1:, 0] > cells[:-1, 1]])
    ends = np.concatenate([starts[1:], [True]])
    return np.stack([cells[starts, 0], np.maximum.accumulate(cells[:, 1])[ends]], axis=1)


def once_grinding(sc: Problem, rounds: int, nonempty: np.ndarray) -> list[np.ndarray] | None:
    """feasible_angles(sc) when the search's round `rounds` (1-based) proved many of its
    boxes empty late (CUT_FROM_ROUND, CUT_SHARE, CUT_MIN_EMPTY; nonempty: the round's boxes
    not proven empty), else None."""
    empty = len(nonempty) - int(np.count_nonzero(nonempty))
    if rounds < CUT_FROM_ROUND or empty < max(CUT_MIN_EMPTY, CUT_SHARE * len(nonempty)):
        return None
    return feasible_angles(sc)


def clip_to_feasible(intervals: np.ndarray, ta: np.ndarray, tb: np.ndarray):
    """(ta', tb'): [ta, tb] cut to the hull of its intersection with the intervals (rows of
    feasible_angles); ta' > tb' where it misses them all."""
    if not len(intervals):
        return np.full_like(ta, np.inf), np.full_like(tb, -np.inf)
    s, e = intervals[:, 0], intervals[:, 1]
    i = np.searchsorted(e, ta, side="left")  # first interval ending at or after ta
    j = np.searchsorted(s, tb, side="right") - 1  # last interval starting at or before tb
    a = np.where(i < len(s), np.maximum(ta, s[np.minimum(i, len(s) - 1)]), np.inf)
    b = np.where(j >= 0, np.minimum(tb, e[np.maximum(j, 0)]), -np.inf)
    return a, b


def clip_to_cap(sc: Problem, r0b, ta: np.ndarray, tb: np.ndarray, caps: np.ndarray):
    """(ta', tb'), (K, n): each slave's angles [ta, tb] of a box with r0 <= r0b cut to those
    where its C5 floor lies below its C8 ceiling; ta' > tb' where none does. caps (K, 1):
    slave_ranges.c8_cap.

    Why. Both limits of a slave are taken at their own favourable end of the box's angles, so
    a box across the crossing of the C5 floor and the C8 ceiling (the static-power slave's
    vertex from h_amb_min 1.2 m on in Figure 3) is bounded with its slave both at the ceiling
    of one end and at the angle of the other: a bound looser than the optimum by about the
    angle width, which the search closes only with boxes some 1e-5 rad wide. feasible_angles
    cannot cut there: the ceiling grows with r0, and it takes the whole master interval.

    Proof. A feasible point has S_min cos(theta) / Theta_3dB <= r (C5) and r |sin(theta -
    theta_0)| <= cap r0 <= cap r0b (C8), so g(theta) = cos(theta) |sin(theta - theta_0)| <=
    kappa = cap r0b Theta_3dB / S_min. With 2 g = sin(2 theta - theta_0) - sin(theta_0) above
    theta_0 and sin(theta_0) - sin(2 theta - theta_0) below, g falls then rises on
    M = [theta_0 / 2 - pi / 4, theta_0 / 2 + pi / 4], where 2 theta - theta_0 is within pi/2
    of 0; so on M it holds exactly between (theta_0 + asin(sin(theta_0) -/+ 2 kappa)) / 2,
    the arcsine's argument clipped to [-1, 1]. Only boxes inside M (and in [0, pi/2)) are cut."""
    if not (sc.on("C5") and sc.on("C8")):
        return ta, tb
    lo, hi = cap_interval(sc, r0b, caps)
    span_lo, span_hi = cap_span(sc)
    inside = (ta >= span_lo) & (tb <= span_hi)
    return np.where(inside, np.maximum(ta, lo), ta), np.where(inside, np.minimum(tb, hi), tb)


def cap_span(sc: Problem) -> tuple[float, float]:
    """M within [0, pi/2): the angles where clip_to_cap's interval is exact (see there)."""
    return max(0.0, 0.5 * sc.th0 - 0.25 * np.pi), min(0.5 * sc.th0 + 0.25 * np.pi, 0.5 * np.pi)


def cap_interval(sc: Problem, r0, caps):
    """(lo, hi): clip_to_cap's angles where a slave's C5 floor is below its C8 ceiling at
    master range r0, for slave angles within M (see there); every angle when S_min = 0 (no
    C5 floor, no crossing)."""
    if sc.p.swath_min <= 0.0:
        shape = np.broadcast(caps, r0).shape
        return np.full(shape, -np.inf), np.full(shape, np.inf)
    kappa = caps * np.maximum(r0, 0.0) * sc.p.beamwidth / sc.p.swath_min
    return (0.5 * (sc.th0 + np.arcsin(np.clip(sc.sin0 - 2.0 * kappa, -1.0, 1.0))),
            0.5 * (sc.th0 + np.arcsin(np.clip(sc.sin0 + 2.0 * kappa, -1.0, 1.0))))
