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

import math
from collections.abc import Iterable
from dataclasses import replace
from itertools import combinations

import numpy as np

from uav_insar_planner.params import Params
from uav_insar_planner.solver import blocking, rays
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


# one slave (a problem's slaves) -> (domain, boxes): the final boxes of the last search that
# proved a problem on it alone empty, with that problem's domain (`_covering`)
Proofs = dict[tuple[int, ...], tuple]


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


def _search(sc: Problem, max_nodes: int, proofs: Proofs | None) -> branch_bound.SearchResult:
    """branch_bound.search for a feasible point of sc; a one-slave problem's starts from the
    last proof's boxes on that slave (`_covering`) and, when it proves sc empty, leaves its
    own for the next."""
    if proofs is None or len(sc.slaves) != 1:
        return branch_bound.search(sc, max_nodes=max_nodes, stop_when_feasible=True)
    boxes = _covering(sc, proofs.get(sc.slaves))
    res = branch_bound.search(sc, max_nodes=max_nodes, stop_when_feasible=True, keep_leaves=True,
                              boxes=boxes if boxes is None or len(boxes) < max_nodes else None)
    if res.exhausted and res.point is None and res.leaves is not None and len(res.leaves):
        proofs[sc.slaves] = (_domain(sc), res.leaves)
    return res


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
                    witnesses: Witnesses | None = None, held: Held | None = None,
                    proofs: Proofs | None = None) -> tuple[bool, bool]:
    """(feasible, proven): is (P) with only the families `on` (plus C2) feasible? The branch
    and bound decides most cases in milliseconds, both ways, and a few near a feasibility edge
    with more boxes (DECIDE_NODES); when it runs out undecided (few families left make its box
    huge), the closed-form start grid decides, and an infeasible verdict is then not proven.
    proofs: see `_search` (a one-slave (P), single-baseline's)."""
    sc = make_problem(p, scheme, "bound", frozenset(blocking.FAMILIES) - on)
    if _witnessed(sc, witnesses, held) or _refuted(sc, witnesses):
        return not _refuted(sc, witnesses), True
    if _blocked_first(sc, witnesses):
        return False, True
    for max_nodes in DECIDE_NODES:
        with np.errstate(all="ignore"):
            res = _search(sc, max_nodes, proofs)
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


def one_slave_set(p: Params, scheme: str, held: Held | None = None, point: tuple | None = None,
                  proofs: Proofs | None = None) -> frozenset[str] | None:
    """A family set proven infeasible for (P) on one slave alone, or None when no slave alone
    is provably blocked with every family on. Dropping the other slaves (and their C4 pairs)
    relaxes (P), so a family set infeasible for one slave is infeasible for (P). The deletion
    filter runs on that relaxation, whose boxes are 2-D: a trial takes about 1 ms either way,
    where proving a trial of (P) empty takes 3-20 ms (Figure 4 at 17.5 Mbit/s). Every trial
    that (P)'s filter finds infeasible holds (P)'s final irreducible set, so when this set is
    that one (as there), all of them are free and only the feasible trials, decided by a found
    point, are searched. For the same reason a trial that drops at least the families of a
    relaxation of (P) held feasible (`held`: the sweep's, e.g. every one without C10 at Figure
    4's first infeasible point) is feasible without a search. Each trial's search starts from
    the last proof's boxes (`_search`, `proofs`): the filter's trials only drop families, so
    most close in one round. `point`: a likely place of (P)'s optimum (the previous sweep
    point's); the filter then runs within the families `_grown` proves infeasible from it
    instead of all of them, fewer trials, and that set is as proven. With one slave (P itself)
    only then, and None without a point."""
    base = make_problem(p, scheme, "bound")
    proofs = {} if proofs is None else proofs

    def search(k: int, on: frozenset[str]) -> branch_bound.SearchResult | None:
        sc = replace(make_problem(p, scheme, "bound", frozenset(blocking.FAMILIES) - on),
                     slaves=(k,))
        if _held(sc, held):
            return None
        with np.errstate(all="ignore"):
            j = base.slaves.index(k)
            if point is not None and len(point[1]) == len(base.slaves) and (
                    got := local_refine.accepted(sc, (point[0], point[1][j:j + 1],
                                                      point[2][j:j + 1]))) is not None:
                # the ray model accepts the point's slave k: sc is feasible, as in _witnessed
                return branch_bound.SearchResult(math.inf, got, -math.inf, 0, False)
            return _search(sc, DECIDE_NODES[0], proofs)

    def empty(k: int, on: frozenset[str]) -> bool:
        res = search(k, on)  # undecided counts as feasible: kept
        return res is not None and res.exhausted and res.point is None

    for j, k in enumerate(base.slaves):
        within = None if point is None or len(point[1]) != len(base.slaves) else _grown(
            p, scheme, k, (point[0], point[1][j], point[2][j]), search)
        if within is None and len(base.slaves) < 2:
            return None  # a single slave's relaxation is (P) itself: its own filter
        if within is not None or empty(k, within := frozenset(blocking.FAMILIES)):
            return frozenset(blocking.irreducible_set(within, lambda on, k=k: not empty(k, on)))
    return None


# Relative distance to a family's bound within which a point counts as on it (`_grown`)
ACTIVE_TOL = 1e-6


def _grown(p: Params, scheme: str, k: int, point: tuple, search) -> frozenset[str] | None:
    """A family set proven infeasible for slave k alone (`search`(k, families): one_slave_set's),
    guessed from `point` (r0, theta_k, r_k), or None. The guess starts with the families that
    point is on or breaks (`_families_at`: the previous optimum's active ones and what the
    step tightened); while slave k has a feasible point under it, the families that point
    breaks join it (it breaks one at least unless slave k is not blocked at all: None). Only
    the final search's proof makes the set infeasible; the guess only says where to look."""
    single = {f: frozenset({f, "C10"} if f in RATE_PRICED else {f}) for f in blocking.FAMILIES}
    alone = {on: make_problem(p, scheme, "bound", frozenset(blocking.FAMILIES) - on)
             for on in single.values()}
    guess = _families_at(alone, k, point, ACTIVE_TOL)
    while guess:
        res = search(k, guess)
        if res is None or not res.exhausted and res.point is None:
            return None  # held feasible (no point to grow from) or undecided
        if res.point is None:
            return guess
        more = _families_at(alone, k, (res.point[0], res.point[1][0], res.point[2][0]), 0.0)
        if more <= guess:
            return None
        guess |= more
    return None


# C9 and C11 bound a UAV's position only with C10's price of rate per distance (without C10 the
# cheapest schedule is no power at all: power.station_radius_sq)
RATE_PRICED = ("C9", "C11")


def _families_at(alone: dict[frozenset[str], Problem], k: int, point: tuple,
                 tol: float) -> frozenset[str]:
    """The union of the family sets of `alone` (each with its problem, those families alone
    on) whose problem's domain or ray limits for slave k the point (r0, theta, r) misses or
    meets within tol (relative)."""
    r0, th, r = point
    out: set[str] = set()
    for on, sc in alone.items():
        lo, up = rays.ray_limits(sc, k, r0, th)
        h1, h2 = rays.master_hole(sc, r0, th)
        e, a = tol * abs(r), tol * max(abs(th), 1.0)
        e0 = 0.0 if sc.fixed_master else tol * abs(r0)
        if not (sc.r0_lo + e0 <= r0 <= sc.r0_hi - e0 and sc.th_lo + a <= th <= sc.th_hi - a
                and lo + e <= r <= up - e and not h1 - e < r < h2 + e):
            out |= on
    return frozenset(out)


def proof_of(sc: Problem, res: branch_bound.SearchResult) -> Proofs | None:
    """The final boxes of res, a search (keep_leaves) that proved sc empty, as `irreducible_set`'s
    start; one slave only: there they are 2-D, like its trials'."""
    if len(sc.slaves) != 1 or not res.exhausted or res.leaves is None or not len(res.leaves):
        return None
    return {sc.slaves: (_domain(sc), res.leaves)}


def _domain(sc: Problem) -> tuple[float, float, float, float]:
    return sc.r0_lo, sc.r0_hi, sc.th_lo, sc.th_hi


def _covering(sc: Problem, proof: tuple | None) -> np.ndarray | None:
    """The final boxes of `proof` (domain, boxes), a search's that proved a problem on sc's one
    slave empty, when that domain is sc's: they cover it (branch_bound.SearchResult.leaves),
    and any boxes that do are a valid start (branch_bound.search), each bounded afresh for sc.
    The filter's trials only drop families, and a box the last proof closed with a family sc
    keeps closes again at once, without the splits that found it (0.2-0.3 ms a proof instead
    of 0.6-1). None (the search's own root) otherwise: where the domain grew, the strips
    around the old boxes cost more than a search from the root (measured)."""
    if proof is None or proof[0] != _domain(sc):
        return None
    return proof[1]


def irreducible_set(p: Params, scheme: str, hint: Iterable[str] = (),
                    witnesses: Witnesses | None = None,
                    hint_proven: bool = False, held: Held | None = None,
                    start: Proofs | None = None) -> tuple[list[str], bool]:
    """(families, proven): the deletion filter over FAMILIES with `decide_families` as the
    test: families that cannot hold together, each needed for that; proven: their
    infeasibility is the branch and bound's proof, not the start grid's verdict. `hint` (the
    previous sweep point's set) saves the trials that hold it, once it is proven infeasible
    here (module docstring), or already proven (hint_proven: the previous point's problem
    held this one's, warm.restricts); without a proven hint, `one_slave_set` stands in for it.
    The relaxations `witnesses` holds proven infeasible are such sets too (a trial keeping
    every family one keeps is infeasible). The result is the one without any of them: they
    only decide trials that hold a set proven infeasible. `witnesses`, `held`: see the module
    docstring and Held. `start`: the boxes of (P)'s own proof of emptiness when it has one
    slave (`_search`, whose later proofs the filter's next trials start from)."""
    everything = frozenset(blocking.FAMILIES)
    covers: Proofs = dict(start or {})
    proofs: dict[frozenset[str], bool] = {everything - off: False for off, point in (
        witnesses or {}).items() if point is None}

    def feasible(on: frozenset[str]) -> bool:
        if any(not ok and known <= on for known, ok in proofs.items()):
            return False  # holds a proven infeasible set
        ok, proven = decide_families(p, scheme, on, witnesses, held, covers)
        if proven:
            proofs[on] = ok
        return ok

    if (known := frozenset(hint)) and known <= everything:
        if hint_proven:
            proofs[known] = False
        else:
            feasible(known)
    if proofs.get(known) is not False and (alone := one_slave_set(
            p, scheme, held, (witnesses or {}).get(frozenset()), covers)):
        proofs[alone] = False
    block = blocking.irreducible_set(blocking.FAMILIES, feasible)
    key = frozenset(block)
    if key not in proofs:
        feasible(key)
    return block, proofs.get(key) is False
