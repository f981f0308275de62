"""Which constraint families block an infeasible scenario, decided by the branch and bound.

`blocking_sets` gives the smallest family sets whose removal alone makes the scenario feasible
(which relaxations would help), proven with the branch and bound of branch_bound.py in
feasibility mode. `irreducible_set` gives the families that cannot hold together (an irreducible
infeasible set: the deletion filter of solver/blocking.py), deciding each trial with the same
search and falling back to the closed-form start grid (solver/start_grid.py) when few families
are left and the search's box becomes huge. C2 is structural and never dropped (FAMILIES).
"""
from __future__ import annotations

from itertools import combinations

import numpy as np

from uav_insar_planner.params import Params
from uav_insar_planner.solver import blocking
from uav_insar_planner.solver.global_opt import branch_bound
from uav_insar_planner.solver.problem import make_problem
from uav_insar_planner.solver.start_grid import find_start


def feasible_without(p: Params, scheme: str, off: frozenset[str],
                     max_nodes: int = 50_000) -> bool:
    """True when a feasible point of (P) minus the families `off` is found."""
    sc = make_problem(p, scheme, "bound", off)
    res = branch_bound.search(sc, max_nodes=max_nodes, stop_when_feasible=True)
    return res.point is not None


def blocking_sets(p: Params, scheme: str, max_size: int = 3) -> tuple[list[str], list[list[str]]]:
    """(first, all): smallest family sets whose removal makes the scenario feasible, in the
    order C1..C11; ([], []) when none of size <= max_size does."""
    with np.errstate(all="ignore"):
        for size in range(1, max_size + 1):
            found = [list(s) for s in combinations(blocking.FAMILIES, size)
                     if feasible_without(p, scheme, frozenset(s))]
            if found:
                return found[0], found
    return [], []


def feasible_families(p: Params, scheme: str, on: frozenset[str],
                      max_nodes: int = 2_000) -> bool:
    """Is (P) with only the families `on` (plus C2) feasible? The branch and bound decides
    most cases in milliseconds, both ways; when its node budget runs out undecided (few
    families left make its box huge), the closed-form start grid decides."""
    sc = make_problem(p, scheme, "bound", frozenset(blocking.FAMILIES) - on)
    with np.errstate(all="ignore"):
        res = branch_bound.search(sc, max_nodes=max_nodes, stop_when_feasible=True)
    if res.point is not None:
        return True
    if res.exhausted:
        return False
    return find_start(p, scheme, on | {"C2"}, first=True) is not None


def irreducible_set(p: Params, scheme: str) -> list[str]:
    """The deletion filter over FAMILIES with `feasible_families` as the test: families that
    cannot hold together, each needed for that."""
    return blocking.irreducible_set(
        blocking.FAMILIES, lambda on: feasible_families(p, scheme, on))
