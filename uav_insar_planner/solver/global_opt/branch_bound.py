"""Branch and bound over boxes of (r0, theta_1, ..., theta_K): the global optimum and its proof.

After C2 (master on the ray theta_0) and the Pareto reduction of the slave ranges
(slave_ranges.py), problem (P) is a minimisation over r0 in the master interval and the K slave
look angles in the C3/C7 domain. Each box gets

- an upper bound: the objective of a feasible point (slave_sets.ranges_for at the box's angle
  centre and smallest r0: exact for K <= 2, a feasible greedy placement beyond), which also
  supplies the returned plan;
- a lower bound (slave_sets.box_lower_bound): every factor of the objective is monotone in r0,
  in |theta - theta_0| or in the slave range, and every range limit is monotone in r0 and in
  an angle, so replacing each by its most favourable value over the box bounds the objective
  from below over all feasible points of the box (+inf proves the box empty). Once the search
  keeps proving boxes empty late (angle_domain.CUT_FROM_ROUND), each box's angles are first
  cut to the slave's provably feasible ones (angle_domain.py): every feasible point stays.

Boxes whose lower bound is within `rel_gap` of the incumbent are closed; the smallest lower
bound of the closed and the still open boxes is a lower bound on the global optimum.

Symmetry: slaves with equal station disks (equal disk_r2: the same rate and energy budget)
and equal C8 rungs (model.h_amb_min_of: all equal unless h_amb_ratio > 1) are
interchangeable, since every other constraint treats the slaves alike. Permuting such
slaves maps any point onto one whose angles are ordered (theta_i <= theta_j for i < j in the
group) with the same objective, so only the ordered part of the space is searched: a box is
cut to theta_j >= theta_i's lower end and theta_i <= theta_j's upper end (which keeps every
ordered point) and dropped when that leaves nothing.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.solver.global_opt import (
    angle_domain,
    box_splits,
    local_refine,
    slave_sets,
)
from uav_insar_planner.solver.problem import Problem


@dataclass
class SearchResult:
    """value: best objective found (+inf: none); point: (r0, slave angles, slave ranges), the
    angles and ranges one per slave of sc.slaves; lower_bound: proven bound on the optimum
    (+inf when infeasibility is proven); exhausted: every box was closed (the certificate is
    complete); refined: the point is local_refine's (no better box centre turned up);
    stopped: why an unfinished search stopped ("node limit" or "time budget"); leaves (with
    keep_leaves): the boxes the search ended with, closed, proven empty or open, which cover
    the searched domain (the next point of a sweep may start from them), and leaf_lb their
    proven lower bounds (+inf: empty); angles: the feasible angles the search used
    (angle_domain.feasible_angles), if it used them."""

    value: float
    point: tuple[float, tuple[float, ...], tuple[float, ...]] | None
    lower_bound: float
    nodes: int
    exhausted: bool
    refined: bool = False
    stopped: str = ""
    leaves: np.ndarray | None = None
    leaf_lb: np.ndarray | None = None
    angles: list[np.ndarray] | None = None


def interchangeable_pairs(sc: Problem) -> list[tuple[int, int]]:
    """(i, j), i < j positions in sc.slaves, consecutive members of a group of slaves with
    equal station disks and equal C8 rungs: ordering each such pair orders the whole group.
    (Slaves on different rungs are not interchangeable: swapping them breaks C8.)"""
    pairs, last = [], {}
    for j, k in enumerate(sc.slaves):
        key = (sc.disk_r2[k], model.h_amb_min_of(sc.p, k) if sc.on("C8") else 0.0)
        if key in last:
            pairs.append((last[key], j))
        last[key] = j
    return pairs


def _order(boxes: np.ndarray, pairs: list[tuple[int, int]]) -> np.ndarray:
    """Cut the boxes to the ordered angles of the interchangeable slaves (module docstring)."""
    return _ordered(boxes, pairs)[0]


def _ordered(boxes: np.ndarray, pairs: list[tuple[int, int]]):
    """(_order's boxes, the mask of the input boxes they come from)."""
    if not pairs:
        return boxes, np.ones(len(boxes), dtype=bool)
    boxes = boxes.copy()
    for seq in (pairs, pairs[::-1]):  # forward and back, so a chain's cuts propagate
        for i, j in seq:
            ia, ib = slave_sets.angle_cols(i)
            ja, jb = slave_sets.angle_cols(j)
            boxes[:, ja] = np.maximum(boxes[:, ja], boxes[:, ia])
            boxes[:, ib] = np.minimum(boxes[:, ib], boxes[:, jb])
    keep = np.ones(len(boxes), dtype=bool)
    for i, j in pairs:
        keep &= boxes[:, slave_sets.angle_cols(i)[0]] <= boxes[:, slave_sets.angle_cols(i)[1]]
        keep &= boxes[:, slave_sets.angle_cols(j)[0]] <= boxes[:, slave_sets.angle_cols(j)[1]]
    return boxes[keep], keep


# A search with no feasible point after this many boxes asks once whether one slave alone is
# blocked (a_slave_is_blocked; whether it is depends on the problem only, not on the boxes).
# Figure 4's first infeasible point (proposed, 17.5 Mbit/s) proves it in 700 boxes of 2-D
# search, where the full search took 20 000 boxes, 13 ms, to reach the old threshold.
PROJECT_AFTER = 2_000
# A round bisects its boxes until there are about batch / ROUND_FILL of them, each at most
# ROUND_SPLITS times.
ROUND_FILL = 4
ROUND_SPLITS = 4


def a_slave_is_blocked(sc: Problem) -> bool:
    """Is some slave alone (the others dropped, a relaxation) provably without a feasible
    position? Near a feasibility edge this 2-D proof is far cheaper than the full one, which
    would keep splitting the other slaves' angles."""
    for k in sc.slaves:
        res = search(replace(sc, slaves=(k,)), stop_when_feasible=True)
        if res.exhausted and res.point is None:
            return True
    return False


def _incumbent(sc: Problem, boxes: np.ndarray):
    """Objective and point at each box's angle centre and smallest r0 (the objective grows
    with r0 for fixed slaves, so the optimum r0 is usually the smallest feasible one)."""
    r0 = boxes[:, box_splits.R0A]
    th = 0.5 * (boxes[:, 2::2] + boxes[:, 3::2])
    f, ranges = slave_sets.ranges_for(sc, r0, th)
    if not len(f):
        return math.inf, None
    i = int(np.argmin(f))
    return float(f[i]), (float(r0[i]), tuple(map(float, th[i])), tuple(map(float, ranges[i])))


# Rounds of box centres before a search without an incumbent asks its `fallback` for one.
FALLBACK_ROUNDS = 2
# Local solves (SLSQP, some milliseconds each) of new incumbents per search.
MAX_REFINES = 4
# SLSQP runs from the most promising box: while no feasible point is known, and every
# STALL_ROUNDS rounds.
MAX_RESCUES = 4
STALL_ROUNDS = 8
# Box centres tried for a better incumbent per round: those of the smallest lower bounds.
INCUMBENT_BOXES = 64
# With a landed first incumbent (search's `landed`), box centres are tried only when the
# smallest open bound stops closing in on it: its gap to the incumbent shrank by less than
# the factor LANDED_SHRINK in the last round (while the incumbent is the optimum the gap about
# halves a round, each open box being bisected about four times: Table I), and every
# LANDED_EVERY rounds whatever the gap.
LANDED_SHRINK = 0.75
LANDED_EVERY = 10


def _most_promising(boxes: np.ndarray, lb: np.ndarray) -> np.ndarray:
    if len(boxes) <= INCUMBENT_BOXES:
        return boxes
    return boxes[np.argpartition(lb, INCUMBENT_BOXES)[:INCUMBENT_BOXES]]


@dataclass
class _LocalSearch:
    """The search's use of local_refine: SLSQP from a markedly better incumbent (so that
    boxes close against, usually, the optimum from then on), and from the most promising box
    every STALL_ROUNDS rounds (first, when no box centre is feasible at all: tight packings in
    small station disks; then when the feasible points near the bound are too thin for box
    centres to hit, e.g. slaves pressed against the master and each other)."""

    refines: int = 0
    rescues: int = 0
    rounds: int = 0
    last: tuple | None = None
    fallback: Callable[[], tuple | None] | None = None

    def first_point(self, rounds: int) -> tuple | None:
        """(value, point) from `fallback` (a costlier start, e.g. SLSQP's, checked feasible by
        the caller), asked once when FALLBACK_ROUNDS rounds of box centres found no
        incumbent; else None."""
        if self.fallback is None or rounds < FALLBACK_ROUNDS:
            return None
        got, self.fallback = self.fallback(), None
        return got

    def improve(self, sc: Problem, f: float, pt, close_below: float, boxes, lb):
        self.rounds += 1
        if self.refines < MAX_REFINES and f < close_below:
            f, pt, _ = local_refine.refine(sc, pt, f)
            self.refines, self.last = self.refines + 1, pt
        elif (self.rescues < MAX_RESCUES and len(lb)
              and (not close_below < math.inf or self.rounds % STALL_ROUNDS == 0)):
            f_box, pt_box = local_refine.from_box(sc, boxes[int(np.argmin(lb))])
            self.rescues += 1
            if f_box < f:
                f, pt, self.last = f_box, pt_box, pt_box
        return f, pt


def _coarse_splits(k_count: int, landed: bool = False) -> int:
    """Bisections of the root before the first round: a few thousand boxes, so that the first
    incumbent is already good; for two slaves with a landed incumbent (a vertex, usually the
    optimum) 128 boxes, which the rounds refine only near it (Table I: 1 888 boxes instead of
    2 416, 8 % faster)."""
    return 7 if k_count == 1 or (k_count == 2 and landed) else 10 if k_count == 2 else 12


def _root_boxes(sc: Problem, pairs: list[tuple[int, int]], landed: bool = False,
                toward=None) -> np.ndarray:
    """The domain split _coarse_splits times (ordered after each split when slaves are
    interchangeable: fewer boxes); toward: a landed incumbent's point, toward which the boxes
    holding it are then bisected (box_splits.toward)."""
    k_count = len(sc.slaves)
    boxes = np.array([[sc.r0_lo, sc.r0_hi] + [sc.th_lo, sc.th_hi] * k_count])
    if not pairs:
        boxes = box_splits.split(sc, boxes, _coarse_splits(k_count, landed))
    else:
        for _ in range(_coarse_splits(k_count, landed)):
            boxes = _order(box_splits.split(sc, boxes), pairs)
    return boxes if toward is None else box_splits.toward(sc, boxes, toward)


def search(sc: Problem, rel_gap: float = 5e-5, max_nodes: int = 400_000, batch: int = 4096,
           stop_when_feasible: bool = False, refine: bool = False,
           time_budget_s: float | None = None, *, incumbent: tuple | None = None,
           boxes: np.ndarray | None = None, box_lb: np.ndarray | None = None,
           keep_leaves: bool = False, landed: bool = False,
           angles: list[np.ndarray] | None = None,
           fallback: Callable[[], tuple | None] | None = None) -> SearchResult:
    """Best-first (in batches) branch and bound; see the module docstring. refine: take
    markedly better incumbents (up to MAX_REFINES) to their local optimum (local_refine),
    which the optimisation wants and a feasibility test does not. time_budget_s: stop after
    the round that passes it, as at the node limit (the open boxes keep the lower bound
    valid, and `exhausted` is False).

    A warm start (solver/global_opt/warm.py, along a sweep): `incumbent`, (value, point)
    checked feasible for sc by the caller, is the first upper bound; `boxes`, which must cover
    sc's domain, replace the root's coarse split, with `box_lb` (if given) proven lower bounds
    of sc's objective over them (_bounds); keep_leaves returns the final boxes and bounds
    (`leaves`, `leaf_lb`). landed: the incumbent is a local optimum (local_refine's); box
    centres are then tried only when the bound stalls (LANDED_SHRINK, LANDED_EVERY: they
    rarely beat a vertex, and cost as much as the bound); `refined`: whether it stood.
    angles: per slave, intervals outside which it has no feasible angle (an earlier sweep
    point's feasible_angles, valid where sc restricts its problem: warm.restricts), cutting
    the boxes from the first round on. fallback: see _LocalSearch.first_point."""
    deadline = math.inf if time_budget_s is None else time.monotonic() + time_budget_s
    if sc.r0_lo > sc.r0_hi or sc.th_lo > sc.th_hi:
        return SearchResult(math.inf, None, math.inf, 0, True)
    pairs = interchangeable_pairs(sc)
    landed = landed and incumbent is not None
    if boxes is None:
        boxes = _root_boxes(sc, pairs, landed, incumbent[1] if landed else None)
    best_val, best_pt = incumbent if incumbent is not None else (math.inf, None)
    gap = math.inf  # the last round's relative gap of the smallest bound to the incumbent
    local = _LocalSearch(last=best_pt if landed else None, fallback=fallback)
    rounds, closed_lb, nodes, leaves = 0, math.inf, len(boxes), []  # leaves: (boxes, bounds)
    parked, parked_lb, project_at = boxes[:0], np.empty(0), PROJECT_AFTER
    while True:
        boxes, kept = _ordered(boxes, pairs)
        lb = _bounds(sc, boxes, best_val * (1.0 - rel_gap),
                     None if box_lb is None else box_lb[kept], angles)
        box_lb = None  # given for the first round's boxes only
        keep = np.isfinite(lb)
        if keep_leaves:
            leaves.append((boxes[~keep], lb[~keep]))
        boxes, lb = boxes[keep], lb[keep]
        rounds += 1
        angles = angles or angle_domain.once_grinding(sc, rounds, keep)
        seen, gap = gap, (best_val - float(lb.min())) / best_val if len(lb) else 0.0
        if not landed or rounds % LANDED_EVERY == 0 or gap > LANDED_SHRINK * seen:
            f, pt = _incumbent(sc, _most_promising(boxes, lb))
            if refine:
                f, pt = local.improve(sc, f, pt, best_val * (1.0 - rel_gap), boxes, lb)
            if f < best_val:
                best_val, best_pt = f, pt
        if best_pt is None and (got := local.first_point(rounds)) is not None:
            best_val, best_pt = got
        if stop_when_feasible and best_pt is not None:
            return SearchResult(best_val, best_pt, -math.inf, nodes, False)
        boxes, lb = np.concatenate([boxes, parked]), np.concatenate([lb, parked_lb])
        done = lb >= best_val * (1.0 - rel_gap)
        if done.any():
            closed_lb = min(closed_lb, float(lb[done].min()))
            if keep_leaves:
                leaves.append((boxes[done], lb[done]))
        boxes, lb = boxes[~done], lb[~done]
        if not len(boxes) or nodes >= max_nodes or time.monotonic() > deadline:
            break
        if len(sc.slaves) > 1 and best_pt is None and nodes >= project_at:
            if a_slave_is_blocked(sc):
                return SearchResult(math.inf, None, math.inf, nodes, True)
            project_at = math.inf  # asked once: the answer depends on sc alone
        boxes, parked, parked_lb = _next_round(sc, boxes, lb, batch)
        nodes += len(boxes)
    lower = min(closed_lb, float(lb.min()) if len(boxes) else math.inf, best_val)
    stopped = "" if not len(boxes) else "node limit" if nodes >= max_nodes else "time budget"
    kept = ([np.concatenate(part) for part in zip(*leaves, (boxes, lb), strict=True)]
            if keep_leaves else ())
    return SearchResult(best_val, best_pt, lower, nodes, not len(boxes),
                        refined=best_pt is not None and best_pt is local.last, stopped=stopped,
                        leaves=kept[0] if kept else None, leaf_lb=kept[1] if kept else None,
                        angles=angles)


def _next_round(sc: Problem, boxes: np.ndarray, lb: np.ndarray, batch: int):
    """(the next round's boxes, the parked boxes, their bounds): the `batch` open boxes of the
    smallest bounds split, the rest parked."""
    if len(boxes) > batch:
        order = np.argpartition(lb, batch)
        parked, parked_lb = boxes[order[batch:]], lb[order[batch:]]
        boxes = boxes[order[:batch]]
    else:
        parked, parked_lb = boxes[:0], lb[:0]
    # Few open boxes: bisect each several times per round (the cost of a round is mostly
    # fixed numpy overhead, so fewer, fuller rounds are faster).
    times = max(1, min(ROUND_SPLITS, int(math.log2(batch / ROUND_FILL / len(boxes)))))
    return box_splits.split(sc, boxes, times), parked, parked_lb


def _bounds(sc: Problem, boxes: np.ndarray, close_at: float, known: np.ndarray | None,
            angles: list[np.ndarray] | None = None):
    """box_lower_bound of the boxes (with the angle cut, when `angles` is given), computed
    only where the `known` proven bounds (if any) are below close_at; the larger of the two
    where both are known."""
    if known is None:
        return slave_sets.box_lower_bound(sc, boxes, close_at=close_at, angles=angles)
    lb = known.copy()
    fresh = known < close_at
    if fresh.any():
        lb[fresh] = np.maximum(known[fresh], slave_sets.box_lower_bound(
            sc, boxes[fresh], close_at=close_at, angles=angles))
    return lb
