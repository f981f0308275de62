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
tightening way, or in a speed step that passes `speed_restricts`) keeps more: the new
feasible set lies inside the old one and the objective is no smaller at any point, so every
lower bound proven over a box before still holds over it (the minimum of a function no
smaller, over a subset, is no smaller). The carried boxes keep their bounds (`leaf_lb`), and
the search computes a bound afresh only where the carried one no longer closes the box. A box
proven empty stays empty, so it is not carried at all: the boxes then cover the feasible set
of every later point of a chain of such steps, not the domain (`partial`), and are carried
only along such steps; past LEAVES_MAX boxes, only their non-empty part is carried.
An infeasibility proven before stays proven, and so does every family set proven infeasible
(the previous irreducible set is infeasible here without a search). The slaves' feasible angles
proven before (angle_domain.py) contain the new ones, so the search cuts its boxes to them from
its first round, without proving them again.

A step in the survey speed v_y (`speed_mps`, survey/speed.py). v_y enters the ray model in two
places only. gamma_m = K / v_y (model.gamma_m) is read by C6 and by the objective, through

    gamma_SNR(r0, r) = ((1 + r0^3 / gamma_m) (1 + r0^2 r / gamma_m))^(-1/2)    (eqs. 7-9),

and the slots' along-track positions y_n = n v_y delta_t are read by the station disk of
C9-C11 alone (power.station_radius_sq), R_k^2 = min(peak_k, energy_k) with

    peak_k = P_max / c_k - max_n (y_n - g_y)^2,
    energy_k = E_max,k / (N delta_t c_k) - mean_n (y_n - g_y)^2

(the static-power scheme: its fixed power / c_k - max_n (y_n - g_y)^2; a navigation error
shrinks each radius by the same e, which keeps the order). At any fixed point x,
sigma_h(x) = lambda r0 sin(theta_0) / (2 pi sqrt(sum_k w_k)) with w_k = b_perp,k^2 2 n_L g_k^2 /
(1 - g_k^2) and g_k = gamma_Rg gamma_SNR gamma_other: w_k rises with g_k, g_k with gamma_m
(`multilook`: its phase std falls with g_k too; `bound` does not read gamma_m), so
sigma_h(x; v') >= sigma_h(x; v) when gamma_m(v') <= gamma_m(v), i.e. v' >= v; and C6,
(1 + r0^3/gamma_m)(1 + r0^2 r/gamma_m) <= 1/gamma_SNR^min^2, only tightens then. So a step
up restricts (P), F(v') inside F(v), when no term of any disk grows, and then

    lb_v(B) <= min over F(v) ∩ B of sigma_h(.; v) <= min over F(v') ∩ B of sigma_h(.; v')

for every box B: each carried bound, empty box and infeasibility proof holds at v'.
`speed_restricts` checks gamma_m(v') <= gamma_m(v) and that max_n and mean_n of
(y_n - g_y)^2 do not fall, which every term of every UAV's disk reads alone, so that the
feasible set of every relaxation the deletion filter tries (C9 or C11 dropped) shrinks as
well. max_n (y_n - g_y)^2 = max(g_y^2, ((N - 1) v delta_t - g_y)^2) never falls as v grows;
mean_n (y_n - g_y)^2 is a parabola in v, falling below v = g_y mean(n) / (delta_t mean(n^2))
(Table I: 2.82 m/s), where a step up widens C11's disk and is no restriction. A step down
raises gamma_m, which lowers sigma_h and widens C6: never one. So bounds are carried as
they are only up, and at Table I only past that speed.

As they are they close little: sigma_h rises about 0.6 % a 0.25 m/s step at Table I, and
most final boxes hold bounds within that of the optimum. speed_carry.py scales them, box by
box and either way of the step, by a proven rho_B (sigma_h(x; v') >= rho_B sigma_h(x; v) at
the points where the minimum over the box lies), and where the optimum slides with v it
moves the boxes with it instead, every bound computed afresh (`speed_boxes`).

So a warm solve certifies what a cold one does, to the same gap; only its route differs.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from uav_insar_planner.solver.global_opt import branch_bound, speed_carry
from uav_insar_planner.solver.problem import Problem

# Parameters that only bound the feasible set of (P), tighter as they grow, and that the
# objective (sigma_h, eqs. 13-15) does not read: h_amb_min_m is C8's b_perp,k <= lambda r_0
# sin(theta_0) / (2 h_amb,k^min) (model.baseline_max) and nothing else; rate_min_mbps is C10's
# R_k >= (1 + mu) R_min,k (schemes.planned_rate_bps: a smaller station disk) and nothing else
# of the plan (the power schedule of a formation changes, not its feasibility otherwise).
TIGHTER_AS_THEY_GROW = ("h_amb_min_m", "rate_min_mbps")
# The speed, a restriction only where speed_restricts proves it (module docstring).
SPEED = "speed_mps"
# The families whose removal takes each of them out of the constraints of (P) altogether:
# h_amb_min_m is read by C8 alone; rate_min_mbps by C10, and through its price per unit
# distance (power.rate_cost) by the station disk that C9 and C11 bound, which without C10 is
# the whole plane (the cheapest schedule is then no power at all: power.station_radius_sq);
# speed_mps by C6 (gamma_m) and that disk (the slots' y_n). A relaxation without them is the
# same feasibility problem before and after a step in the parameter.
READ_ONLY_BY = {"h_amb_min_m": ("C8",), "rate_min_mbps": ("C10",), SPEED: ("C6", "C10")}
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


def _changed(before: Problem, sc: Problem) -> set[str]:
    """The parameters (raw keys) whose values differ between the two problems."""
    old, new = before.p.raw, sc.p.raw
    return {key for key in set(old) | set(new) if old.get(key) != new.get(key)}


def restricts(warm: WarmStart, sc: Problem) -> bool:
    """Is sc a restriction of the previous point's problem whose objective is nowhere
    smaller: the same scheme, objective and families, every parameter equal but those of
    TIGHTER_AS_THEY_GROW, each no smaller (element by element), and the speed, where
    speed_restricts holds?"""
    if warm.problem is None or (warm.problem.scheme, warm.problem.objective,
                                warm.problem.off) != (sc.scheme, sc.objective, sc.off):
        return False
    before, p = warm.problem.p, sc.p
    if before.energy_budget_uav_j != p.energy_budget_uav_j:
        return False
    changed = _changed(warm.problem, sc)
    for key in changed - {SPEED}:
        if key not in TIGHTER_AS_THEY_GROW:
            return False
        old, new = (np.atleast_1d(np.asarray(value, dtype=float))
                    for value in (before.raw.get(key), p.raw.get(key)))
        if old.shape != new.shape or not np.all(new >= old):
            return False
    return SPEED not in changed or speed_restricts(warm.problem, sc)


def speed_restricts(before: Problem, sc: Problem) -> bool:
    """gamma_m no larger and the slots no nearer the station, in their largest and their mean
    squared along-track distance (module docstring): with the other parameters as `restricts`
    allows, every term of every station disk is then no larger, so sc's feasible set, and
    each relaxation's, lies inside before's, and its objective is nowhere smaller."""
    if not sc.gm <= before.gm:
        return False
    old, new = ((q.p.y_track - q.p.ground_station[1]) ** 2 for q in (before, sc))
    return bool(new.max() >= old.max() and new.mean() >= old.mean())


def held_here(warm: WarmStart, sc: Problem,
              restricted: bool | None = None) -> set[frozenset[str]]:
    """The relaxations (families off) proven feasible at sc before any test
    (infeasibility.Held), from those proven at the previous point (`held`: after a feasible
    point, frozenset(), which its optimum proves; after an infeasible one, those its filter
    found feasible). Only along a step that `restricts`, and then each grown by the families
    that read a parameter the step changed (READ_ONLY_BY): a relaxation without them is the
    same problem as at the previous point, and it held the old relaxation's feasible set, so
    it is feasible still. Without them a relaxation's feasible set may have shrunk: its
    witness is tested afresh (infeasibility._witnessed). Empty after any other step.
    restricted: restricts(warm, sc), when the caller has it."""
    if not (restricts(warm, sc) if restricted is None else restricted):
        return set()
    swept = frozenset(family for key in _changed(warm.problem, sc)
                      for family in READ_ONLY_BY[key])
    return {off | swept for off in warm.held}


def forget_refuted(warm: WarmStart) -> None:
    """Drop the relaxations proven infeasible (infeasibility.Witnesses' None): they hold only
    while each step restricts the one before."""
    warm.witnesses = {off: point for off, point in warm.witnesses.items() if point is not None}


def _bounds_of(sc: Problem, domain: tuple) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) ends of (r0, theta_1, ..., theta_K) of a domain_of tuple."""
    k_count = len(sc.slaves)
    return (np.array([domain[2]] + [domain[4]] * k_count),
            np.array([domain[3]] + [domain[5]] * k_count))


def _covers(warm: WarmStart, sc: Problem) -> bool:
    """Were the previous boxes searched over sc's slaves and (scheme, objective, families),
    with no interchangeable pair that sc lacks (module docstring)?"""
    new = domain_of(sc)
    return (warm.leaves is not None and warm.domain is not None
            and warm.domain[0] == new[0] and warm.domain[1] <= new[1]
            and tuple(warm.domain[6:]) == new[6:])


def start_boxes(sc: Problem, warm: WarmStart,
                restricted: bool = False) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(boxes, lower bounds): the previous final boxes cut to sc's domain when they cover it,
    else (None, None); when `restricted` (restricts), those not proven empty (module
    docstring) with their carried lower bounds, else all of them and None. At most
    LEAVES_MAX boxes."""
    if not _covers(warm, sc) or (warm.partial and not restricted):
        return None, None
    old_lo, old_hi = _bounds_of(sc, warm.domain)
    lo, hi = _bounds_of(sc, domain_of(sc))
    if np.any(lo < old_lo) or np.any(hi > old_hi):
        return None, None
    boxes = warm.leaves.copy()
    boxes[:, 0::2] = np.maximum(boxes[:, 0::2], lo)
    boxes[:, 1::2] = np.minimum(boxes[:, 1::2], hi)
    keep = np.all(boxes[:, 0::2] <= boxes[:, 1::2], axis=1)
    if restricted and warm.leaf_lb is not None:
        keep &= np.isfinite(warm.leaf_lb)
    if not keep.any() or keep.sum() > LEAVES_MAX:
        return None, None
    lb = warm.leaf_lb[keep] if restricted and warm.leaf_lb is not None else None
    return boxes[keep], lb


def speed_step(warm: WarmStart, sc: Problem) -> bool:
    """Is sc the previous point's problem at another speed only (speed_boxes' steps)?"""
    return warm.problem is not None and _changed(warm.problem, sc) == {SPEED}


def speed_boxes(sc: Problem, warm: WarmStart, point, restricted: bool):
    """For a step in the speed alone (speed_step) whose incumbent is `point` (r0, angles,
    ...): (boxes, their carried lower bounds or None, partial), speed_carry.boxes' from the
    previous final boxes, moved by the optimum's move (one mean shift for each group of
    interchangeable slaves, so that the ordered region maps onto itself) or in place; (None,
    None, False) where they do not cover sc's domain or are too many. Boxes that left out the
    empty ones (`partial`, after a restricting step) serve a restricting step only, in place."""
    if (not _covers(warm, sc) or warm.leaf_lb is None or warm.point is None
            or (warm.partial and not restricted)):
        return None, None, False
    old_lo, old_hi = _bounds_of(sc, warm.domain)
    lo, hi = _bounds_of(sc, domain_of(sc))
    if np.any(lo < old_lo) or np.any(hi > old_hi):
        return None, None, False
    shift = np.array([point[0], *point[1]]) - np.array([warm.point[0], *warm.point[1]])
    shift[1:] = _tied(shift[1:], warm.domain[1])
    if warm.partial:
        shift[:] = 0.0
    boxes, bounds = speed_carry.boxes(warm.problem, sc, warm.leaves, warm.leaf_lb,
                                      (old_lo, old_hi), shift, restricted)
    return boxes, bounds, warm.partial and boxes is not None


def _tied(shift: np.ndarray, pairs) -> np.ndarray:
    """The slaves' angle shifts with each group of interchangeable slaves (pairs of
    positions, branch_bound.interchangeable_pairs) given its members' mean shift."""
    group = np.arange(len(shift))
    for i, j in sorted(pairs):
        group[group == group[j]] = group[i]
    means = {g: float(shift[group == g].mean()) for g in set(group.tolist())}
    return np.array([means[g] for g in group.tolist()])


def remember(warm: WarmStart, sc: Problem, point, res: branch_bound.SearchResult | None,
             blocking: tuple[str, ...] = (), held: set | None = None,
             partial: bool = False) -> None:
    """Keep this solve's optimum (None: infeasible; `infeasible` when the search proved it),
    final boxes with their bounds, parameters, proven blocking set and the relaxations proven
    feasible here (`held`, of an infeasible point; a feasible one's optimum holds them all).
    partial: the search started from the boxes of a restricting step that left out the
    empty ones (module docstring)."""
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
    if leaves is not None and len(leaves) > speed_carry.MOVED_MAX:
        kept = np.isfinite(lb)
        leaves, lb, partial = leaves[kept], lb[kept], True
    keep = leaves is not None and 0 < len(leaves) <= speed_carry.MOVED_MAX
    warm.leaves = leaves if keep else None
    warm.leaf_lb = lb if keep else None
    warm.domain = domain_of(sc) if keep else None
    warm.partial = partial
    warm.angles = None if res is None else res.angles
