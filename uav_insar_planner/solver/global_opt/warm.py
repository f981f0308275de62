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

A step that only tightens (P) (`restricts`: the new point differs from the previous one only
in parameters that bound the feasible set and do not enter the objective, each moved the
tightening way) keeps more: the new feasible set lies inside the old one and the objective is
the same function, so every lower bound proven over a box before still holds over it (the
minimum over a subset is no smaller). The carried boxes keep their bounds (`leaf_lb`), and the
search computes a bound afresh only where the carried one no longer closes the box. A box
proven empty stays empty, so it is not carried at all: the boxes then cover the feasible set
of every later point of a chain of such steps, not the domain (`partial`), and are carried
only along such steps; should they grow past LEAVES_MAX, only their non-empty part is kept.
An infeasibility proven before stays proven, and so does every family set proven infeasible
(the previous irreducible set is infeasible here without a search). The slaves' feasible angles
proven before (angle_domain.py) contain the new ones, so the search cuts its boxes to them from
its first round, without proving them again.

So a warm solve certifies what a cold one does, to the same gap; only its route differs.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from uav_insar_planner.solver.global_opt import branch_bound
from uav_insar_planner.solver.problem import Problem

# Parameters that only bound the feasible set of (P), tighter as they grow, and that the
# objective (sigma_h, eqs. 13-15) does not read: h_amb_min_m is C8's b_perp,k <= lambda r_0
# sin(theta_0) / (2 h_amb,k^min) (model.baseline_max) and nothing else; rate_min_mbps is C10's
# R_k >= (1 + mu) R_min,k (schemes.planned_rate_bps: a smaller station disk) and nothing else
# of the plan (the power schedule of a formation changes, not its feasibility otherwise).
TIGHTER_AS_THEY_GROW = ("h_amb_min_m", "rate_min_mbps")
# The family whose removal takes each of them out of (P) altogether: h_amb_min_m is read by C8
# alone; rate_min_mbps by C10, and through its price per unit distance (power.rate_cost) by
# the station disk that C9 and C11 bound, which without C10 is the whole plane (the cheapest
# schedule is then no power at all: power.station_radius_sq). A relaxation without that family
# is the same problem before and after a step in the parameter.
READ_ONLY_BY = {"h_amb_min_m": "C8", "rate_min_mbps": "C10"}
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
    leaf_lb: np.ndarray | None = None
    domain: tuple | None = None
    problem: Problem | None = None
    infeasible: bool = False
    blocking: tuple[str, ...] = ()
    witnesses: dict = field(default_factory=dict)
    angles: list | None = None
    held: set = field(default_factory=set)
    partial: bool = False
    used_incumbent: bool = False
    used_leaves: bool = False
    used_blocking: bool = False


def domain_of(sc: Problem) -> tuple:
    """What the validity of carried boxes depends on (module docstring)."""
    return (sc.slaves, frozenset(branch_bound.interchangeable_pairs(sc)),
            sc.r0_lo, sc.r0_hi, sc.th_lo, sc.th_hi, sc.scheme, sc.objective, sc.off)


def restricts(warm: WarmStart, sc: Problem) -> bool:
    """Is sc a restriction of the previous point's problem with the same objective: the same
    scheme, objective and families, every parameter equal but those of TIGHTER_AS_THEY_GROW,
    each no smaller (element by element)?"""
    if warm.problem is None or (warm.problem.scheme, warm.problem.objective,
                                warm.problem.off) != (sc.scheme, sc.objective, sc.off):
        return False
    before, p = warm.problem.p, sc.p
    if before.energy_budget_uav_j != p.energy_budget_uav_j:
        return False
    for key in set(before.raw) | set(p.raw):
        old, new = before.raw.get(key), p.raw.get(key)
        if old == new:
            continue
        if key not in TIGHTER_AS_THEY_GROW:
            return False
        old, new = np.atleast_1d(np.asarray(old, dtype=float)), np.atleast_1d(
            np.asarray(new, dtype=float))
        if old.shape != new.shape or not np.all(new >= old):
            return False
    return True


def held_here(warm: WarmStart, sc: Problem) -> set[frozenset[str]]:
    """The relaxations (families off) proven feasible at sc before any test
    (infeasibility.Held), from those proven at the previous point (`held`: after a feasible
    point, frozenset(), which its optimum proves; after an infeasible one, those its filter
    found feasible). Only along a step that `restricts`, and then each grown by the families
    that read a parameter the step changed (READ_ONLY_BY): a relaxation without them is the
    same problem as at the previous point, and it held the old relaxation's feasible set, so
    it is feasible still. Without them a relaxation's feasible set may have shrunk: its
    witness is tested afresh (infeasibility._witnessed). Empty after any other step."""
    if not restricts(warm, sc):
        return set()
    before, p = warm.problem.p, sc.p
    swept = frozenset(family for key, family in READ_ONLY_BY.items()
                      if before.raw.get(key) != p.raw.get(key))
    return {off | swept for off in warm.held}


def forget_refuted(warm: WarmStart) -> None:
    """Drop the relaxations proven infeasible (infeasibility.Witnesses' None): they hold only
    while each step restricts the one before."""
    warm.witnesses = {off: point for off, point in warm.witnesses.items() if point is not None}


def start_boxes(sc: Problem, warm: WarmStart,
                restricted: bool = False) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(boxes, lower bounds): the previous final boxes cut to sc's domain when they cover it,
    else (None, None); when `restricted` (restricts), those not proven empty (module
    docstring) with their carried lower bounds, else all of them and None."""
    if warm.leaves is None or warm.domain is None or (warm.partial and not restricted):
        return None, None
    slaves, pairs, r0_lo, r0_hi, th_lo, th_hi, *problem = warm.domain
    new = domain_of(sc)
    if (new[0] != slaves or not pairs <= new[1] or sc.r0_lo < r0_lo or sc.r0_hi > r0_hi
            or sc.th_lo < th_lo or sc.th_hi > th_hi or tuple(problem) != new[6:]):
        return None, None
    boxes = warm.leaves.copy()
    boxes[:, 0::2] = np.maximum(boxes[:, 0::2], [sc.r0_lo] + [sc.th_lo] * len(sc.slaves))
    boxes[:, 1::2] = np.minimum(boxes[:, 1::2], [sc.r0_hi] + [sc.th_hi] * len(sc.slaves))
    keep = np.all(boxes[:, 0::2] <= boxes[:, 1::2], axis=1)
    if restricted and warm.leaf_lb is not None:
        keep &= np.isfinite(warm.leaf_lb)
    if not keep.any():
        return None, None
    lb = warm.leaf_lb[keep] if restricted and warm.leaf_lb is not None else None
    return boxes[keep], lb


def remember(warm: WarmStart, sc: Problem, point, res: branch_bound.SearchResult | None,
             blocking: tuple[str, ...] = (), held: set | None = None,
             partial: bool = False) -> None:
    """Keep this solve's optimum (None: infeasible; `infeasible` when the search proved it),
    final boxes with their bounds, parameters, proven blocking set and the relaxations proven
    feasible here (`held`, of an infeasible point; a feasible one's optimum holds them all).
    partial: the search started from `start_boxes`' boxes of a restricting step (module
    docstring)."""
    warm.point, warm.blocking, warm.problem = point, blocking, sc
    warm.held = set() if held is None else held
    if point is not None:
        # a feasible point of (P) itself, the relaxation with no family off: at the next
        # point, should it be infeasible, a likely witness of each relaxation the filter tries
        warm.witnesses[frozenset()] = point
        warm.held = {frozenset()}
    warm.infeasible = point is None and res is not None and res.exhausted
    leaves = None if res is None else res.leaves
    lb = None if res is None else res.leaf_lb
    if leaves is not None and len(leaves) > LEAVES_MAX:
        kept = np.isfinite(lb)
        leaves, lb, partial = leaves[kept], lb[kept], True
    keep = leaves is not None and 0 < len(leaves) <= LEAVES_MAX
    warm.leaves = leaves if keep else None
    warm.leaf_lb = lb if keep else None
    warm.domain = domain_of(sc) if keep else None
    warm.partial = partial
    warm.angles = None if res is None else res.angles
