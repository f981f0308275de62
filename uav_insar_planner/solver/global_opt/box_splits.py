"""How the branch and bound (branch_bound.py) bisects its boxes: which coordinate
(`split_scores`, the one whose width loosens the bound most), how many times (`split`), and
toward a point (`toward`, a landed incumbent's). A box is one row [r0_a, r0_b, theta_1a,
theta_1b, ...] (slave_sets.angle_cols); every split keeps what the boxes cover.
"""
from __future__ import annotations

import numpy as np

from uav_insar_planner.solver.problem import Problem

R0A, R0B = 0, 1

# Weight of a box's relative r0 width against its angle widths (split_scores), by the
# number of slaves. The objective moves by about 2 per relative change of r0, and for one or
# two slaves (the exact inner solve) that is the weight. With three or more the bound loosens
# faster: it takes each slave's C8 top at the box's largest r0 (b_max grows with r0) and its
# weight at the smallest, and C4 passes that slack on to the slaves pressed below a
# C8-capped neighbour. 8 was chosen by measurement (boxes to close; Table I grown to K = 3..5,
# the five-UAV d_min 6 m h_amb_ratio 1.25 scenario, 30 random three- and four-slave swarms at
# d_min 4-6 m of benchmarks/global_solver_hard.py): it needed 0.23-0.95x the boxes of 2 on
# all of them but one random swarm (1.6x), and 1.13x at h_amb_ratio 1 with five UAVs at
# d_min 6 m; 4, 10 and 16 did worse than 8 overall. For K = 2 it does not pay (a
# static-power sweep point of test_solver_global went past the node limit).
R0_WEIGHT_FEW, R0_WEIGHT_MANY = 2.0, 8.0


def split_scores(sc: Problem, b: np.ndarray) -> np.ndarray:
    """(n, 1 + K): how much each coordinate's width loosens the bound (0: r0, j + 1: slave
    j's angle); the widest by this measure is halved. The objective's relative sensitivity is
    about 1/|tan(theta - theta_0)| per radian of a slave angle (b_perp), plus the coherence
    terms; the bound's per relative change of r0 is R0_WEIGHT_FEW or R0_WEIGHT_MANY (see
    there)."""
    weight = R0_WEIGHT_MANY if len(sc.slaves) >= 3 else R0_WEIGHT_FEW
    with np.errstate(divide="ignore"):  # a box from r0 = 0 is infinitely wide: split r0
        r0w = weight * (b[:, R0B] - b[:, R0A]) / b[:, R0A]
    ta, tb = b[:, 2::2], b[:, 3::2]
    sens = 1.0 / np.maximum(np.abs(np.tan(0.5 * (ta + tb) - sc.th0)), 0.02) + 3.0
    return np.concatenate([r0w[:, None], (tb - ta) * sens], axis=1)


def split(sc: Problem, b: np.ndarray, times: int = 1) -> np.ndarray:
    """Each box halved `times` times, each time along its widest coordinate by split_scores
    (the children's scores taken as the parent's with the halved one halved: one evaluation
    for all levels, unless a box still reaches r0 = 0)."""
    scores = split_scores(sc, b)
    from_zero = sc.r0_lo <= 0.0  # only then can a box's r0 score be infinite
    for _ in range(times):
        dim = np.argmax(scores, axis=1)
        rows = np.arange(len(b))
        lo_col, hi_col = 2 * dim, 2 * dim + 1
        mid = 0.5 * (b[rows, lo_col] + b[rows, hi_col])
        left, right = b.copy(), b.copy()
        left[rows, hi_col] = mid
        right[rows, lo_col] = mid
        scores[rows, dim] *= 0.5
        b, scores = np.concatenate([left, right]), np.concatenate([scores, scores])
        if from_zero and np.isinf(scores[:, 0]).any():
            scores = split_scores(sc, b)
    return b


# A landed first incumbent (usually the optimum's vertex) is where the rounds narrow the boxes
# down to; the root's boxes holding it are bisected this many times toward it before the
# first round, which saves the rounds' first steps there (Table I: 5 rounds instead of 8,
# 4.7-4.8 instead of 5.2 ms). Measured 0, 8, 12, 16, 24 on Table I and 52 cold points of the
# figure sweeps: 8 and 12 did best on Table I, 8 left the sweep points as they were (12
# cost them 6 %). From carried boxes (a warm start) it did not pay: the open boxes there lie
# along the curve a sliding optimum leaves, not around the point.
TOWARD_LEVELS = 8


def toward(sc: Problem, boxes: np.ndarray, point, levels: int = TOWARD_LEVELS) -> np.ndarray:
    """The boxes holding `point` (r0, angles, ...) bisected `levels` times toward it: each
    time the half holding it is bisected again and the other half kept. The boxes still
    cover what they covered."""
    x = np.array([point[0], *point[1]])
    has = np.all((boxes[:, 0::2] <= x) & (x <= boxes[:, 1::2]), axis=1)
    kept, cur = [boxes[~has]], boxes[has]
    for _ in range(levels if has.any() else 0):
        kids = split(sc, cur)
        inside = np.all((kids[:, 0::2] <= x) & (x <= kids[:, 1::2]), axis=1)
        kept.append(kids[~inside])
        cur = kids[inside]
    return np.concatenate([*kept, cur])
