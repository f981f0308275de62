"""Certified global solver of problem (P) for the four schemes and the three objectives.

`solve_global` reduces (P) to the master range r0 and the slave look angles (solver/rays.py:
C2, and every other constraint an interval of slave ranges along each look-angle ray;
slave_ranges.py: the slaves sit at the top of their feasible ranges, or one steps down to keep
C4 between them) and runs the branch and bound of branch_bound.py, whose smallest open or closed
box bound is a proven lower bound on the objective over the feasible set. Its first incumbent,
where there is one, is the chain of chain_packing.py taken to a local optimum by SLSQP: often
the optimum itself, which the search then only has to certify. An empty search (every box
proven empty) proves infeasibility; the blocking constraint families are then an irreducible
infeasible set and the message adds the smallest sets whose removal alone makes it feasible
(infeasibility.py).
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import Params
from uav_insar_planner.solver import power, rays
from uav_insar_planner.solver.global_opt import (
    angle_domain,
    branch_bound,
    chain_packing,
    infeasibility,
    local_refine,
    slave_ranges,
    slave_sets,
    warm,
)
from uav_insar_planner.solver.problem import Problem, make_problem
from uav_insar_planner.solver.result import SolverResult
from uav_insar_planner.swarm import MASTER

# Branch and bound closes a box when its bound is within REL_GAP of the incumbent, so the
# reported relative gap is at most REL_GAP (the target is 1e-4).
REL_GAP = 5e-5
# The compass search after SLSQP starts at this fraction of the domain's widths.
POLISH_STEP = 1e-3
# From this many slaves the chain's incumbent and bound (chain_packing.py) come first; the
# branch and bound runs only when they leave a gap (its box bound needs every slave's angle
# box narrow, which takes exponentially many boxes in K). Measured on Table I grown to K
# slaves: the chain certifies K = 3..6 in about 0.1 s each, the branch and bound takes 0.06,
# 0.35 and 0.8 s for K = 3, 4, 5.
CHAIN_MIN_K = 4
# Fewer slaves: the chain's point is only the search's first incumbent (the search finds its
# own when the chain is not the optimum), from this many starts along the C8 line.
LANDED_STARTS = 100
# A warm incumbent's slave moved to its C5/C8 crossing (warm_incumbent) goes this far inside.
CAP_NUDGE = 1e-9


def _nan_result(p: Params, nodes: int, **kw) -> SolverResult:
    return SolverResult(feasible=False, formation=np.full((p.num_uavs, 2), np.nan),
                        p_com=np.zeros((p.num_uavs, p.num_slots)), iterations=nodes, **kw)


def master_on_c2(p: Params) -> bool:
    """Fixed-master scheme: does q0_fixed satisfy C2 (to the checker's tolerance)?"""
    x0, z0 = p.master_fixed
    return abs(x0 - float(model.master_x(z0, p.x_t, p.theta0))) <= 1e-6


def formation_of(sc: Problem, point) -> np.ndarray:
    """(num_uavs, 2) formation from the search point
    (r0, slave angles, slave ranges), one angle and range per slave of sc.slaves; NaN row for
    a UAV not flown."""
    r0, thetas, ranges = point
    q = np.full((sc.p.num_uavs, 2), np.nan)
    if sc.fixed_master:
        q[MASTER] = sc.p.master_fixed
    else:
        q[MASTER] = rays.position(sc, r0, sc.th0)
    for k, r, t in zip(sc.slaves, ranges, thetas, strict=True):
        q[k] = rays.position(sc, r, t)
    return q


def solve_global(p: Params, scheme: str, objective: str,
                 time_budget_s: float | None = None, *,
                 warm_start: warm.WarmStart | None = None) -> SolverResult:
    """Global minimum of sigma_h (`exact`, eq. 15), of Proposition 1's bound (`bound`) or of
    sigma_h with the exact multilook phase std (`multilook`, multilook.phase_std in eq. 13)
    over C1..C11 for `scheme`, with a certificate: lower_bound <= optimum <= objective.

    A search that reaches its node limit or `time_budget_s` (seconds of branch and bound;
    None: the scenario's `p.time_budget_s`, where 0 is no limit but the nodes) returns the best
    feasible plan found with its proven lower bound and gap, and its message says the
    certificate is incomplete.

    `warm_start` (a sweep's, warm.py): read for the first incumbent, the starting boxes and the
    infeasibility hint, each re-checked here, and overwritten with this solve's."""
    if time_budget_s is None and p.time_budget_s > 0.0:
        time_budget_s = p.time_budget_s
    if warm_start is not None:
        warm_start.used_incumbent = warm_start.used_leaves = warm_start.used_blocking = False
    if scheme == "fixed-master" and not master_on_c2(p):
        return _nan_result(p, 0, blocking=["C2"], lower_bound=math.inf,
                           certificate="q0_fixed violates C2", message="q0_fixed is off the "
                           "master's look-angle line x0 = x_t - z0 tan(theta_0)")
    sc = make_problem(p, scheme, objective)
    clock = time.monotonic()
    chain = _chain_first(sc, time_budget_s)
    if chain is not None and chain[3]:
        value, point, lower, _, intervals, _ = chain
        if warm_start is not None:
            warm.remember(warm_start, sc, point, None)
        return _feasible(p, scheme, sc, value, point, lower, "", (
            f"chain packing bound (solver/global_opt/chain_packing.py) over {intervals} "
            "master-range intervals, all closed"), intervals)
    start = boxes = box_lb = angles = held = None
    partial = False
    if warm_start is not None:
        route = _warm_route(p, scheme, sc, warm_start)
        if isinstance(route, SolverResult):
            return route
        start, boxes, box_lb, angles, partial, held = route
    landed = start is not None and start[2]
    fallback = None
    if start is None and boxes is None:  # cold: the chain's, when SLSQP or the KKT check landed it
        start = _landed_start(sc, chain)
        landed = start is not None
    elif start is None:  # the carried boxes' centres first: the chain's SLSQP costs more
        def fallback():
            got = _landed_start(sc, chain)
            return None if got is None else got[:2]
    start = None if start is None else start[:2]
    left = None if time_budget_s is None else max(0.0, time_budget_s - (time.monotonic() - clock))
    # Two slaves or fewer: the exact inner solve already makes the incumbents good.
    res = branch_bound.search(sc, rel_gap=REL_GAP, refine=len(sc.slaves) > 2,
                              time_budget_s=left, incumbent=start, boxes=boxes,
                              box_lb=box_lb, keep_leaves=warm_start is not None, landed=landed,
                              angles=angles, fallback=fallback)
    if res.point is None and (chain is None or chain[1] is None):
        return _no_point(p, scheme, sc, res, warm_start, held, partial=partial)
    if start is not None and res.point is start[1]:
        res = replace(res, refined=True)  # the refined warm point stood: no second SLSQP
    value, point, lower = _search_point(sc, res, chain)
    if warm_start is not None:
        warm.remember(warm_start, sc, point, res, partial=partial)
    gap = (value - lower) / value
    dims = ", ".join(["r0"] + [f"theta{k}" for k in sc.slaves])
    return _feasible(p, scheme, sc, value, point, lower, "" if res.exhausted else (
        f"certificate incomplete: {res.stopped} reached; the best feasible plan found, "
        f"proven within {gap:.2g} of the optimum"), (
        f"branch and bound over ({dims}) boxes with monotone interval bounds; "
        f"{res.nodes} boxes, " + ("all closed" if res.exhausted else f"{res.stopped} reached")),
        res.nodes)


def _warm_route(p: Params, scheme: str, sc: Problem, state: warm.WarmStart):
    """What the sweep's warm start gives this search (warm.py): (incumbent, boxes, their
    carried bounds, the slaves' feasible angles, partial, the relaxations held), or the answer
    itself where the previous point's proof of infeasibility holds here. A step that restricts
    carries bounds; a step in the speed alone carries them scaled (warm.speed_boxes)."""
    restricted = warm.restricts(state, sc)
    held = warm.held_here(state, sc, restricted)
    if not restricted:
        warm.forget_refuted(state)
    if restricted and state.infeasible:
        return _no_point(p, scheme, sc, branch_bound.SearchResult(
            math.inf, None, math.inf, 0, True), state, held, carried=True)
    speed = warm.speed_step(state, sc)
    start = warm_incumbent(p, sc, state, restricted, followed_only=speed)
    if not speed:
        boxes, box_lb = warm.start_boxes(sc, state, restricted)
        partial = restricted and boxes is not None  # start_boxes left out the empty ones
    elif start is not None:  # without it, the root's split: the point may be infeasible
        boxes, box_lb, partial = warm.speed_boxes(sc, state, start[1], restricted)
    else:
        boxes = box_lb = None
        partial = False
    angles = state.angles if restricted else None
    state.used_incumbent, state.used_leaves = start is not None, boxes is not None
    return start, boxes, box_lb, angles, partial, held


def _chain_first(sc: Problem, time_budget_s: float | None):
    """For CHAIN_MIN_K slaves or more: (value, point, lower, closed, intervals, landed) of the
    chain's incumbent and bound (chain_packing.py), None when it does not apply or finds no
    point."""
    if len(sc.slaves) < CHAIN_MIN_K or not chain_packing.applies(sc):
        return None
    deadline = math.inf if time_budget_s is None else time.monotonic() + time_budget_s
    value, point, landed = chain_packing.chain_incumbent(sc)
    if point is None:
        return None
    lower, closed, intervals = chain_packing.certify(sc, value, point[0], REL_GAP, deadline)
    return value, point, lower, closed, intervals, landed


def _landed_start(sc: Problem, chain):
    """The search's first incumbent, (value, point) of the chain (chain_packing.py) when
    SLSQP landed it on a local optimum: the optimum itself whenever the slaves end up on the
    C8 line d_min apart (Table I), which the search then only has to certify; None when
    there is no such point (the search finds its own)."""
    if chain is None and len(sc.slaves) >= 2 and chain_packing.applies(sc):
        value, point, landed = chain_packing.chain_incumbent(sc, LANDED_STARTS)
        chain = (value, point, None, None, None, landed)
    if chain is None or chain[1] is None or not chain[5]:
        return None
    return chain[0], chain[1], True


def _search_point(sc: Problem, res: branch_bound.SearchResult, chain):
    """(value, point, lower) from the search (and the chain's, when it ran): the incumbent
    taken to the optimum's vertex, the better of the two, the larger proven bound."""
    value, point, lower = math.inf, None, res.lower_bound
    if res.point is not None:
        # The search's incumbent is within REL_GAP of the optimum; SLSQP on the ray
        # coordinates takes it to the optimum's vertex (value <= the incumbent's, re-checked
        # on the ray model), and a compass search on the angles stands in when SLSQP ends
        # off the feasible set.
        value, point, landed = res.value, res.point, res.refined
        if not landed:
            value, point, landed = local_refine.refine(sc, point, value)
        if not landed:
            widths = (sc.r0_hi - sc.r0_lo,) + (sc.th_hi - sc.th_lo,) * len(sc.slaves)
            value, point = local_refine.polish(sc, point, [POLISH_STEP * w for w in widths])
    if chain is not None:
        if chain[0] < value:
            value, point = chain[0], chain[1]
        lower = max(lower, chain[2])  # both are proven lower bounds
    return value, point, min(lower, value)


def _feasible(p: Params, scheme: str, sc: Problem, value: float, point, lower: float,
              message: str, certificate: str, iterations: int) -> SolverResult:
    q = formation_of(sc, point)
    return SolverResult(
        feasible=True, formation=q, p_com=power.schedules(p, q, scheme),
        iterations=iterations, lower_bound=lower, gap=(value - lower) / value,
        certificate=certificate, message=message)


def _kept(sc: Problem, point):
    """(value, point): the previous sweep point's optimum where sc, a restriction of its
    problem (warm.restricts), still accepts it as it is on the ray model (local_refine.accepted,
    no range cut to a lower value); None otherwise. The previous certificate's lower bound
    holds for sc, whose optimum is therefore this value, to that certificate's gap."""
    got = local_refine.accepted(sc, point)
    if got is None:
        return None
    value = local_refine.value_at(sc, got)
    return (value, got) if value <= local_refine.value_at(sc, point) else None


def warm_incumbent(p: Params, sc: Problem, state: warm.WarmStart, restricted: bool = False,
                   followed_only: bool = False):
    """(value, point, landed) of the previous sweep point's optimum carried to this point's
    parameters, or None; landed: a local optimum here (the search then tries fewer box
    centres, branch_bound.search). Its vertex is followed to the new parameters first
    (local_refine.follow: Newton on the same active constraints, accepted at a KKT point).
    Failing that, its master range and angles (cut to the new domain) get their slave ranges
    solved afresh on the ray model; unless that reproduces the previous point exactly, SLSQP
    (local_refine) takes it to its local optimum here, since box centres may miss the new
    optimum by a percent where the feasible set is thin. Only a point the ray model accepts and
    whose formation passes the independent checker (evaluate.py) is returned. (SLSQP from a
    point the ray model rejects was tried: it fails slowly where the new point is infeasible.)
    followed_only: the kept or followed point or None (a speed step: Table I's front at 1 m/s
    spent 35 ms in that SLSQP, the cold start's chain 0.7 ms)."""
    if state.point is None or len(state.point[1]) != len(sc.slaves):
        return None
    followed = _kept(sc, state.point) if restricted else None
    if followed is None and state.problem is not None and state.problem.slaves == sc.slaves:
        followed = local_refine.follow(state.problem, sc, state.point)
    if followed is not None:
        (value, point), landed = followed, True
    elif followed_only:
        return None
    else:
        r0 = float(np.clip(state.point[0], sc.r0_lo, sc.r0_hi))
        th = np.clip(np.asarray(state.point[1], dtype=float), sc.th_lo, sc.th_hi)
        th, moved = _inside_caps(sc, r0, th)
        with np.errstate(all="ignore"):
            f, ranges = slave_sets.ranges_for(sc, np.array([r0]), th[None])
        if not np.isfinite(f[0]):
            return None
        value, point = float(f[0]), (r0, tuple(map(float, th)), tuple(map(float, ranges[0])))
        landed = point == state.point
        if not landed and not moved:
            value, point, landed = local_refine.refine(sc, point, value)
    q = formation_of(sc, point)
    if not evaluate(p, q, power.schedules(p, q, sc.scheme), sc.scheme, sc.objective).feasible:
        return None
    return value, point, landed


def _inside_caps(sc: Problem, r0: float, th: np.ndarray) -> tuple[np.ndarray, bool]:
    """(angles, moved): each slave's angle moved just inside the angles where its C5 floor
    lies below its C8 ceiling at r0 (angle_domain.cap_interval), where it is outside them.
    Along Figure 3's static-power chain the previous vertex's slave falls off its ceiling this
    way as h_amb_min grows (at 0.8 and 1.2 m), and local_refine.follow fails; the new
    vertex is at that crossing. A moved point is only a guess of the new active set: it is not
    taken to SLSQP (measured: 5-13 ms there, more than the search it saves) and is not landed."""
    if not (sc.on("C5") and sc.on("C8")):
        return th, False
    caps = np.array([slave_ranges.c8_cap(sc, k) for k in sc.slaves])
    lo, hi = angle_domain.cap_interval(sc, r0, caps)
    span_lo, span_hi = angle_domain.cap_span(sc)
    off = (th >= span_lo) & (th <= span_hi) & ((th < lo) | (th > hi))
    got = np.where(off, np.clip(th, lo + CAP_NUDGE, hi - CAP_NUDGE), th)
    return got, bool(np.any(got != th))


def _no_point(p: Params, scheme: str, sc: Problem, res: branch_bound.SearchResult,
              state: warm.WarmStart | None = None, held: set | None = None,
              carried: bool = False, partial: bool = False):
    """The answer of a search that found no feasible point: infeasibility proven (every box
    empty) with an irreducible set of families, or not proven within its limit. carried: the
    proof is the previous sweep point's, whose problem this one restricts (warm.restricts),
    and so is the infeasibility of its irreducible set; the relaxations that make it feasible
    are then tried first, within that set (any proven set gives the same ones,
    infeasibility.blocking_sets), so that each one found feasible settles the filter's trials
    that drop at least its families (infeasibility.Held). held: warm.held_here's, grown here.
    partial: the search started without the boxes an earlier point proved empty (warm.py), so
    its boxes cover this problem's feasible set but not the domain of a relaxation: they are
    no start for the filter's trials (infeasibility.proof_of)."""
    hint = state.blocking if state is not None else ()
    seen = state.witnesses if state is not None else None
    fixes = None
    if carried and hint:
        _, fixes = infeasibility.blocking_sets(p, scheme, within=hint, witnesses=seen,
                                               held=held)
    block, proven = infeasibility.irreducible_set(p, scheme, hint, seen, hint_proven=carried,
                                                  held=held, start=None if partial
                                                  else infeasibility.proof_of(sc, res))
    if fixes is None:
        _, fixes = infeasibility.blocking_sets(p, scheme, within=block if proven else (),
                                               witnesses=seen, held=held)
    if state is not None:
        state.used_blocking = bool(hint) and proven and tuple(block) == tuple(hint)
        warm.remember(state, sc, None, res, tuple(block) if proven else (), held, partial)
    relax = ("; relaxing any of these alone makes it feasible: "
             + ", ".join("+".join(s) for s in fixes)) if fixes else ""
    together = " + ".join(block) + (" cannot hold together" if len(block) > 1
                                    else " cannot be met") + relax
    if not res.exhausted:
        return _nan_result(p, res.nodes, blocking=block, lower_bound=res.lower_bound,
                           message="no feasible point found and infeasibility not proven "
                           f"within {res.nodes} boxes ({res.stopped}); " + together)
    how = ("the previous sweep point's proof holds: this point only tightens its "
           + "/".join((*warm.TIGHTER_AS_THEY_GROW, warm.SPEED)) + ", where ") if carried else ""
    return _nan_result(p, res.nodes, blocking=block, lower_bound=math.inf,
                       certificate="infeasible: " + how + "every box of ("
                       + ", ".join(["r0"] + [f"theta{k}" for k in sc.slaves])
                       + ") proven empty by interval bounds of the C1-C11 range limits",
                       message=together)
