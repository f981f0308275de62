"""Which constraint families block an infeasible scenario, decided by the branch and bound.

`blocking_sets` gives the smallest family sets whose removal alone makes the scenario feasible
(which relaxations would help), proven with the branch and bound of branch_bound.py in
feasibility mode. `irreducible_set` gives the families that cannot hold together (an irreducible
infeasible set: the deletion filter of solver/blocking.py), deciding each trial with the same
search and falling back to the closed-form start grid (solver/start_grid.py) when few families
are left and the search's box becomes huge. C2 is structural and never dropped (FAMILIES).

Two facts save trials, neither a guess: every superset of a family set proven infeasible is
infeasible (so a trial that still holds a proven set needs no search: the previous sweep
point's irreducible set, once proven again here, decides most trials of the filter), and a
relaxation that makes the scenario feasible must drop a family of every infeasible set (so
`blocking_sets` tries only the sets that meet the proven irreducible set). Along a sweep,
`witnesses` keeps the feasible point each relaxation's search found; at the next point a
witness that the ray model still accepts inside the new domain proves that relaxation feasible
without a search (local_refine.checked, the test the solver's own plans pass), and so does
the previous point's optimum, kept as the witness of (P) itself (warm.remember). A
relaxation the search proved infeasible is kept as None: it stays proven while the sweep only
tightens (P) (warm.restricts), and warm.py drops it at any other step. Where there is no such
set to start from (the first infeasible point of a sweep, a standalone solve), the filter's
own run on one slave alone finds one in 2-D boxes (`one_slave_set`), and a trial of (P) left
undecided by a short search asks first whether one slave alone is blocked
(branch_bound.a_slave_is_blocked) before the long one.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace
from itertools import combinations

import numpy as np

from uav_insar_planner.params import Params
from uav_insar_planner.solver import blocking
from uav_insar_planner.solver.global_opt import branch_bound, local_refine
from uav_insar_planner.solver.problem import Problem, make_problem
from uav_insar_planner.solver.start_grid import find_start

# Boxes of the feasibility search before the start grid decides (a proof near a feasibility
# edge, e.g. Figure 4 at 17.5 Mbit/s, takes some 30 000; the grid costs 0.2-0.4 s there).
DECIDE_NODES = (2_000, 40_000)


# relaxation (the families off) -> a feasible point of it, or None: proven infeasible
Witnesses = dict[frozenset[str], tuple | None]
# relaxations proven feasible at the current point, witness or not: every relaxation that drops
# at least the same families is feasible too (its feasible set holds theirs), so one entry
# settles all of those without a test (warm.WarmStart.held says what carries to a next point)
Held = set[frozenset[str]]


def _refuted(sc: Problem, witnesses: Witnesses | None) -> bool:
    """Was the relaxation sc.off proven infeasible at a point whose problem holds sc's?"""
    return witnesses is not None and sc.off in witnesses and witnesses[sc.off] is None


def _held(sc: Problem, held: Held | None) -> bool:
    """Is sc.off a relaxation of one proven feasible at this point (Held)?"""
    return held is not None and any(off <= sc.off for off in held)


def _witnessed(sc: Problem, witnesses: Witnesses | None, held: Held | None = None) -> bool:
    """Is sc proven feasible without a search: a relaxation of one held at this point (Held),
    or by a kept feasible point, the one of the relaxation sc.off, else one of a relaxation
    that held more families (frozenset(): a sweep point's optimum, which held them all)? Any
    point the ray model accepts (local_refine.checked, the verdict the solver's own plans get;
    its direct test, local_refine.accepted, first) proves sc feasible; these are only the
    likely ones: at the first infeasible point of a sweep the previous optimum holds every
    relaxation that drops what the step tightened (a trial without C10 in Figure 4), for a
    test of one point instead of a search. The point accepted is kept as sc.off's witness,
    and sc.off held."""
    if _held(sc, held):
        return True
    if witnesses is None or _refuted(sc, witnesses):
        return False
    own = witnesses.get(sc.off)
    points = [own] + [point for off, point in witnesses.items()
                      if point is not None and point is not own and off <= sc.off]
    for point in points:
        if point is None or len(point[1]) != len(sc.slaves):
            continue
        with np.errstate(all="ignore"):
            found = local_refine.accepted(sc, point)
            # the inner solve only for sc's own witness: another relaxation's point that
            # fails as it stands rarely passes it, and a search settles sc either way
            if found is None and point is own and (checked := local_refine.checked(
                    sc, np.array([point[0], *point[1], *point[2]], dtype=float))) is not None:
                found = checked[1]
        if found is not None:
            witnesses[sc.off] = found
            _hold(sc, held)
            return True
    return False


def _hold(sc: Problem, held: Held | None) -> None:
    if held is not None:
        held.add(sc.off)


def _blocked_first(sc: Problem, witnesses: Witnesses | None) -> bool:
    """For a relaxation whose own witness (feasible at an earlier sweep point) the ray model
    rejects here: is one slave alone provably blocked (branch_bound.a_slave_is_blocked, a
    proof)? Such a relaxation has likely crossed its feasibility edge (Figure 4's fixed-master
    without C3 at 18 Mbit/s), where that 2-D proof takes 0.4-2 ms and the search's own, asked
    only after 2 000 boxes, 2-7 ms; when it is still feasible, the 2-D searches stop at their
    first point. A proof is kept as the relaxation's refutation."""
    if (witnesses is None or witnesses.get(sc.off) is None or len(sc.slaves) < 2
            or not branch_bound.a_slave_is_blocked(sc)):
        return False
    witnesses[sc.off] = None
    return True


def _found(sc: Problem, res: branch_bound.SearchResult, witnesses: Witnesses | None,
           held: Held | None = None) -> bool:
    if witnesses is not None and (res.point is not None or res.exhausted):
        witnesses[sc.off] = res.point
    if res.point is not None:
        _hold(sc, held)
    return res.point is not None


def feasible_without(p: Params, scheme: str, off: frozenset[str], max_nodes: int = 50_000,
                     witnesses: Witnesses | None = None, held: Held | None = None) -> bool:
    """True when a feasible point of (P) minus the families `off` is found."""
    sc = make_problem(p, scheme, "bound", off)
    if _witnessed(sc, witnesses, held) or _refuted(sc, witnesses):
        return not _refuted(sc, witnesses)
    if _blocked_first(sc, witnesses):
        return False
    res = branch_bound.search(sc, max_nodes=max_nodes, stop_when_feasible=True)
    return _found(sc, res, witnesses, held)


def blocking_sets(p: Params, scheme: str, max_size: int = 3, within: Iterable[str] = (),
                  witnesses: Witnesses | None = None,
                  held: Held | None = None) -> tuple[list[str], list[list[str]]]:
    """(first, all): smallest family sets whose removal makes the scenario feasible, in the
    order C1..C11; ([], []) when none of size <= max_size does. `within`: a family set proven
    infeasible (irreducible_set's, when proven, or the carried one of a sweep): only sets
    meeting it are tried (any proven set gives the same answer: a relaxation that keeps one
    is infeasible)."""
    need = frozenset(within)
    with np.errstate(all="ignore"):
        for size in range(1, max_size + 1):
            found = [list(s) for s in combinations(blocking.FAMILIES, size)
                     if (not need or need & set(s))
                     and feasible_without(p, scheme, frozenset(s), witnesses=witnesses,
                                          held=held)]
            if found:
                return found[0], found
    return [], []


def decide_families(p: Params, scheme: str, on: frozenset[str],
                    witnesses: Witnesses | None = None,
                    held: Held | None = None) -> tuple[bool, bool]:
    """(feasible, proven): is (P) with only the families `on` (plus C2) feasible? The branch
    and bound decides most cases in milliseconds, both ways, and a few near a feasibility edge
    with more boxes (DECIDE_NODES); when it runs out undecided (few families left make its box
    huge), the closed-form start grid decides, and an infeasible verdict is then not proven."""
    sc = make_problem(p, scheme, "bound", frozenset(blocking.FAMILIES) - on)
    if _witnessed(sc, witnesses, held) or _refuted(sc, witnesses):
        return not _refuted(sc, witnesses), True
    if _blocked_first(sc, witnesses):
        return False, True
    for max_nodes in DECIDE_NODES:
        with np.errstate(all="ignore"):
            res = branch_bound.search(sc, max_nodes=max_nodes, stop_when_feasible=True)
            if res.point is not None or res.exhausted:
                return _found(sc, res, witnesses, held), True
            # Undecided: near a feasibility edge one slave alone is often provably blocked
            # in some 700 boxes, where the full proof takes 20 000 and more (Figure 4 at
            # 17.5 Mbit/s: 1 ms against 15 ms a trial); asked here, before the longer stage
            # (whose search would ask too, but only after redoing these boxes).
            if (max_nodes == DECIDE_NODES[0] and len(sc.slaves) > 1
                    and branch_bound.a_slave_is_blocked(sc)):
                if witnesses is not None:
                    witnesses[sc.off] = None
                return False, True
    found = find_start(p, scheme, on | {"C2"}, first=True) is not None
    return found, found


def one_slave_set(p: Params, scheme: str, held: Held | None = None) -> frozenset[str] | None:
    """A family set proven infeasible for (P) on one slave alone, or None when no slave alone
    is provably blocked with every family on (or there is one slave only: that relaxation is
    (P) itself). Dropping the other slaves (and their C4 pairs) relaxes (P), so a family set
    infeasible for one slave is infeasible for (P). The deletion filter runs on that relaxation,
    whose boxes are 2-D: a trial takes about 1 ms either way, where proving a trial of (P) empty
    takes 3-20 ms (Figure 4 at 17.5 Mbit/s). Every trial that (P)'s filter finds infeasible
    holds (P)'s final irreducible set, so when this set is that one (as there), all of them
    are free and only the feasible trials, decided by a found point, are searched. For the
    same reason a trial that drops at least the families of a relaxation of (P) held feasible
    (`held`: the sweep's, e.g. every one without C10 at Figure 4's first infeasible point) is
    feasible without a search."""
    base = make_problem(p, scheme, "bound")
    if len(base.slaves) < 2:
        return None  # a single slave's relaxation is (P) itself

    def empty(k: int, on: frozenset[str]) -> bool:
        sc = replace(make_problem(p, scheme, "bound", frozenset(blocking.FAMILIES) - on),
                     slaves=(k,))
        if _held(sc, held):
            return False
        with np.errstate(all="ignore"):
            res = branch_bound.search(sc, max_nodes=DECIDE_NODES[0], stop_when_feasible=True)
        return res.exhausted and res.point is None  # undecided counts as feasible: kept

    everything = frozenset(blocking.FAMILIES)
    for k in base.slaves:
        if empty(k, everything):
            return frozenset(blocking.irreducible_set(
                blocking.FAMILIES, lambda on, k=k: not empty(k, on)))
    return None


def irreducible_set(p: Params, scheme: str, hint: Iterable[str] = (),
                    witnesses: Witnesses | None = None,
                    hint_proven: bool = False, held: Held | None = None) -> tuple[list[str], bool]:
    """(families, proven): the deletion filter over FAMILIES with `decide_families` as the
    test: families that cannot hold together, each needed for that; proven: their
    infeasibility is the branch and bound's proof, not the start grid's verdict. `hint` (the
    previous sweep point's set) saves the trials that hold it, once it is proven infeasible
    here (module docstring), or already proven (hint_proven: the previous point's problem
    held this one's, warm.restricts); without a proven hint, `one_slave_set` stands in for it.
    The relaxations `witnesses` holds proven infeasible are such sets too (a trial keeping
    every family one keeps is infeasible). The result is the one without any of them: they
    only decide trials that hold a set proven infeasible. `witnesses`, `held`: see the module
    docstring and Held."""
    everything = frozenset(blocking.FAMILIES)
    proofs: dict[frozenset[str], bool] = {everything - off: False for off, point in (
        witnesses or {}).items() if point is None}

    def feasible(on: frozenset[str]) -> bool:
        if any(not ok and known <= on for known, ok in proofs.items()):
            return False  # holds a proven infeasible set
        ok, proven = decide_families(p, scheme, on, witnesses, held)
        if proven:
            proofs[on] = ok
        return ok

    if (known := frozenset(hint)) and known <= everything:
        if hint_proven:
            proofs[known] = False
        else:
            feasible(known)
    if proofs.get(known) is not False and (alone := one_slave_set(p, scheme, held)):
        proofs[alone] = False
    block = blocking.irreducible_set(blocking.FAMILIES, feasible)
    key = frozenset(block)
    if key not in proofs:
        feasible(key)
    return block, proofs.get(key) is False
