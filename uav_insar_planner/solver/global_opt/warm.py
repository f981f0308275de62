"""Warm starts of the global back end along a sweep: what one solve hands the next.

A sweep (study/sweep.py) solves one scenario after another that differ in one parameter, and
the optimum, the boxes that certified it and the constraints that blocked an infeasible point
move little from one to the next. `WarmStart` carries them; `solve_global` reads it before its
search and writes it after. Nothing of it is trusted at the new point:

- the previous optimum becomes the first incumbent only after its angles and master range are
  solved afresh on the new ray model (slave_sets.ranges_for) and the resulting formation
  passes the independent checker (evaluate.py; optimum.warm_incumbent);
- the previous final boxes replace the coarse split of the root only where they cover the new
  domain: the same slaves, every interchangeable pair of before still interchangeable (the
  ordered region is no larger) and the new master-range and angle intervals inside the old
  ones (`start_boxes` cuts the boxes to them); every bound is computed afresh on them;
- the previous irreducible infeasible set is a hint for the deletion filter only when the
  branch and bound proves it infeasible at the new point, and the feasible points found for
  its relaxations (`witnesses`) count only where the new ray model accepts them
  (infeasibility.py).

So a warm solve certifies what a cold one does, to the same gap; only its route differs.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from uav_insar_planner.solver.global_opt import branch_bound
from uav_insar_planner.solver.problem import Problem

# More final boxes than this are not carried to the next point: a hard point's fine partition
# costs the next, easy point more than the coarse split of its root (measured on the
# static-power points of Figure 3, 160 000 boxes).
LEAVES_MAX = 8192


@dataclass
class WarmStart:
    """State handed along one scheme's sequence of sweep points (module docstring). The
    `used_*` flags say what the last solve took from it."""

    point: tuple | None = None
    leaves: np.ndarray | None = None
    domain: tuple | None = None
    blocking: tuple[str, ...] = ()
    witnesses: dict = field(default_factory=dict)
    used_incumbent: bool = False
    used_leaves: bool = False
    used_blocking: bool = False


def domain_of(sc: Problem) -> tuple:
    """What the validity of carried boxes depends on (module docstring)."""
    return (sc.slaves, frozenset(branch_bound.interchangeable_pairs(sc)),
            sc.r0_lo, sc.r0_hi, sc.th_lo, sc.th_hi)


def start_boxes(sc: Problem, warm: WarmStart) -> np.ndarray | None:
    """The previous final boxes cut to sc's domain when they cover it, else None."""
    if warm.leaves is None or warm.domain is None:
        return None
    slaves, pairs, r0_lo, r0_hi, th_lo, th_hi = warm.domain
    new = domain_of(sc)
    if (new[0] != slaves or not pairs <= new[1] or sc.r0_lo < r0_lo or sc.r0_hi > r0_hi
            or sc.th_lo < th_lo or sc.th_hi > th_hi):
        return None
    boxes = warm.leaves.copy()
    boxes[:, 0::2] = np.maximum(boxes[:, 0::2], [sc.r0_lo] + [sc.th_lo] * len(sc.slaves))
    boxes[:, 1::2] = np.minimum(boxes[:, 1::2], [sc.r0_hi] + [sc.th_hi] * len(sc.slaves))
    keep = np.all(boxes[:, 0::2] <= boxes[:, 1::2], axis=1)
    return boxes[keep] if keep.any() else None


def remember(warm: WarmStart, sc: Problem, point, res: branch_bound.SearchResult | None,
             blocking: tuple[str, ...] = ()) -> None:
    """Keep this solve's optimum (None: infeasible), final boxes and proven blocking set."""
    warm.point, warm.blocking = point, blocking
    leaves = None if res is None else res.leaves
    keep = leaves is not None and 0 < len(leaves) <= LEAVES_MAX
    warm.leaves = leaves if keep else None
    warm.domain = domain_of(sc) if keep else None
