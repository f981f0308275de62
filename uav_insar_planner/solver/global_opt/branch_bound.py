"""Branch and bound over boxes of (r0, theta_1, theta_2): the global optimum and its proof.

After C2 (master on the ray theta_0) and the Pareto reduction of the slave ranges
(slave_ranges.py), problem (P) is a minimisation over r0 in the master interval and the slave
look angles in the C3/C7 domain. Each box gets

- an upper bound: the exact objective of a feasible point (slave_ranges.best_ranges at the
  box's angle centre and smallest r0), which also supplies the returned plan;
- a lower bound (slave_ranges.box_lower_bound): every factor of the objective is monotone in r0,
  in |theta - theta_0| or in the slave range, and every range limit is monotone in r0 and in
  an angle, so replacing each by its most favourable value over the box bounds the objective
  from below over all feasible points of the box (+inf proves the box empty).

Boxes whose lower bound is within `rel_gap` of the incumbent are closed; the smallest lower
bound of the closed and the still open boxes is a lower bound on the global optimum. When the
scenario's slaves are interchangeable (equal station disks), boxes with theta_1 > theta_2 are
dropped: swapping the slaves maps them onto kept points of equal objective.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from uav_insar_planner.solver.global_opt import slave_ranges
from uav_insar_planner.solver.rays import Scenario

R0A, R0B, T1A, T1B, T2A, T2B = range(6)


@dataclass
class SearchResult:
    """value: best objective found (+inf: none); point: (r0, theta1, theta2, r1, r2);
    lower_bound: proven bound on the optimum (+inf when infeasibility is proven);
    exhausted: every box was closed (the certificate is complete)."""

    value: float
    point: tuple[float, float, float, float, float] | None
    lower_bound: float
    nodes: int
    exhausted: bool


def _lower(sc: Scenario, b: np.ndarray) -> np.ndarray:
    return slave_ranges.box_lower_bound(sc, b[:, R0A], b[:, R0B], b[:, T1A], b[:, T1B],
                                 b[:, T2A], b[:, T2B])


def _split_dim(sc: Scenario, b: np.ndarray) -> np.ndarray:
    """Which coordinate to halve: the one whose width most loosens the bound. The objective's
    relative sensitivity is about 2 per relative change of r0 and about
    1/|tan(theta - theta_0)| per radian of a slave angle (b_perp), plus the coherence terms."""
    with np.errstate(divide="ignore"):  # a box from r0 = 0 is infinitely wide: split r0
        r0w = 2.0 * (b[:, R0B] - b[:, R0A]) / b[:, R0A]
    scores = [r0w]
    for a, z in ((T1A, T1B), (T2A, T2B))[:len(sc.slaves)]:
        mid = 0.5 * (b[:, a] + b[:, z]) - sc.th0
        sens = 1.0 / np.maximum(np.abs(np.tan(mid)), 0.02) + 3.0
        scores.append((b[:, z] - b[:, a]) * sens)
    return np.argmax(np.stack(scores), axis=0)


def _split(sc: Scenario, b: np.ndarray) -> np.ndarray:
    dim = _split_dim(sc, b)
    lo_col = np.array([R0A, T1A, T2A])[dim]
    hi_col = lo_col + 1
    rows = np.arange(len(b))
    mid = 0.5 * (b[rows, lo_col] + b[rows, hi_col])
    left, right = b.copy(), b.copy()
    left[rows, hi_col] = mid
    right[rows, lo_col] = mid
    return np.concatenate([left, right])


PROJECT_AFTER = 20_000


def _a_slave_is_blocked(sc: Scenario) -> bool:
    """Is some slave alone (the other dropped, a relaxation) provably without a feasible
    position? Near a feasibility edge this 2-D proof is far cheaper than the 3-D one, which
    would keep splitting the other slave's angle."""
    for k in sc.slaves:
        res = search(replace(sc, slaves=(k,)), stop_when_feasible=True)
        if res.exhausted and res.point is None:
            return True
    return False


def search(sc: Scenario, rel_gap: float = 5e-5, max_nodes: int = 400_000, batch: int = 4096,
           stop_when_feasible: bool = False) -> SearchResult:
    """Best-first (in batches) branch and bound; see the module docstring."""
    if sc.r0_lo > sc.r0_hi or sc.th_lo > sc.th_hi:
        return SearchResult(math.inf, None, math.inf, 0, True)
    two = len(sc.slaves) == 2
    symmetric = two and sc.disk_r2[1] == sc.disk_r2[2]
    root = np.array([[sc.r0_lo, sc.r0_hi, sc.th_lo, sc.th_hi, sc.th_lo, sc.th_hi]])
    # A coarse start: a few thousand boxes, so that the first incumbent is already good.
    boxes = root
    for _ in range(10 if two else 7):
        boxes = _split(sc, boxes)
    best_val, best_pt = math.inf, None
    closed_lb, nodes = math.inf, len(boxes)
    parked, parked_lb = boxes[:0], np.empty(0)
    while True:
        if symmetric:
            boxes = boxes[boxes[:, T1A] <= boxes[:, T2B]]
        lb = _lower(sc, boxes)
        keep = np.isfinite(lb)
        boxes, lb = boxes[keep], lb[keep]
        # Incumbent: each new box's centre in angle at its smallest r0 (the objective grows
        # with r0 for fixed slaves, so the optimum r0 is usually the smallest feasible one).
        r0 = boxes[:, R0A]
        t1 = 0.5 * (boxes[:, T1A] + boxes[:, T1B])
        t2 = 0.5 * (boxes[:, T2A] + boxes[:, T2B])
        f, r1, r2 = slave_ranges.best_ranges(sc, r0, t1, t2 if two else None)
        if len(f) and f.min() < best_val:
            i = int(np.argmin(f))
            best_val = float(f[i])
            best_pt = (float(r0[i]), float(t1[i]), float(t2[i]) if two else math.nan,
                       float(r1[i]), float(r2[i]) if two else math.nan)
        if stop_when_feasible and best_pt is not None:
            return SearchResult(best_val, best_pt, -math.inf, nodes, False)
        boxes, lb = np.concatenate([boxes, parked]), np.concatenate([lb, parked_lb])
        done = lb >= best_val * (1.0 - rel_gap)
        if done.any():
            closed_lb = min(closed_lb, float(lb[done].min()))
        boxes, lb = boxes[~done], lb[~done]
        if not len(boxes) or nodes >= max_nodes:
            break
        if two and best_pt is None and nodes >= PROJECT_AFTER and _a_slave_is_blocked(sc):
            return SearchResult(math.inf, None, math.inf, nodes, True)
        if len(boxes) > batch:
            order = np.argpartition(lb, batch)
            parked, parked_lb = boxes[order[batch:]], lb[order[batch:]]
            boxes = boxes[order[:batch]]
        else:
            parked, parked_lb = boxes[:0], lb[:0]
        # Few open boxes: bisect each several times per round (the cost of a round is mostly
        # fixed numpy overhead, so fewer, fuller rounds are faster).
        for _ in range(max(1, min(4, int(math.log2(batch / 4 / len(boxes)))))):
            boxes = _split(sc, boxes)
        nodes += len(boxes)
    open_lb = float(lb.min()) if len(boxes) else math.inf
    lower = min(closed_lb, open_lb, best_val)
    return SearchResult(best_val, best_pt, lower, nodes, not len(boxes))


def polish(sc: Scenario, point, steps, iterations: int = 80):
    """Compass search from `point` on (r0, theta_1, theta_2) with the exact inner ranges: all
    3^d stencil points at once, move to the best, halve the step when none improves. It only
    ever returns feasible points no worse than `point` (the certificate is unaffected)."""
    two = len(sc.slaves) == 2
    lo = np.array([sc.r0_lo, sc.th_lo, sc.th_lo])
    hi = np.array([sc.r0_hi, sc.th_hi, sc.th_hi])
    x = np.array(point[:3] if two else (point[0], point[1], sc.th0))
    step = np.array(steps, dtype=float)
    if not two:
        step[2] = 0.0
    grid = np.array(np.meshgrid(*[[-1, 0, 1]] * x.size)).reshape(x.size, -1).T  # 3^d stencil
    f0, r1, r2 = slave_ranges.best_ranges(sc, x[:1], x[1:2], x[2:3] if two else None)
    best = (float(f0[0]), tuple(x) + (float(r1[0]), float(r2[0])))
    for _ in range(iterations):
        cand = np.clip(x + grid * step, lo, hi)
        f, r1, r2 = slave_ranges.best_ranges(sc, cand[:, 0], cand[:, 1],
                                             cand[:, 2] if two else None)
        i = int(np.argmin(f))
        if f[i] < best[0]:
            x = cand[i]
            best = (float(f[i]), (float(x[0]), float(x[1]), float(x[2]), float(r1[i]),
                                  float(r2[i])))
        else:
            step *= 0.5
            if np.all(step <= 1e-12 * np.maximum(np.abs(x), 1.0)):
                break
    value, pt = best
    if not two:
        pt = (pt[0], pt[1], math.nan, pt[3], math.nan)
    return value, pt
