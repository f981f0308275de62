"""Which constraint families block an infeasible scenario.

A family set S blocks when (P) without the families in S is feasible. We report a smallest
such set (and the other sets of that size), found by trying sets in order of size; each
try is the branch and bound of certificate.py in feasibility mode on the relaxed scenario.
C2 is structural (it defines the master's ray) and is never dropped; a fixed master off C2 is
reported by the solver directly.
"""
from __future__ import annotations

from itertools import combinations

from uav_insar_planner.params import Params
from uav_insar_planner.solver import certificate, rays

FAMILIES = ("C1", "C3", "C4", "C5", "C6", "C7", "C8", "C9", "C10", "C11")


def feasible_without(p: Params, scheme: str, off: frozenset[str],
                     max_nodes: int = 50_000) -> bool:
    """True when a feasible point of (P) minus the families `off` is found."""
    sc = rays.make_scenario(p, scheme, "bound", off)
    res = certificate.search(sc, max_nodes=max_nodes, stop_when_feasible=True)
    return res.point is not None


def blocking_sets(p: Params, scheme: str, max_size: int = 3) -> tuple[list[str], list[list[str]]]:
    """(first, all): smallest family sets whose removal makes the scenario feasible, in the
    order C1..C11; ([], []) when none of size <= max_size does."""
    for size in range(1, max_size + 1):
        found = [list(s) for s in combinations(FAMILIES, size)
                 if feasible_without(p, scheme, frozenset(s))]
        if found:
            return found[0], found
    return [], []
