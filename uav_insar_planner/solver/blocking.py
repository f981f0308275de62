"""Which constraint families block an infeasible scenario.

`blocking_sets` gives the smallest family sets whose removal alone makes the scenario feasible
(which relaxations would help), proven with the branch and bound of certificate.py in
feasibility mode. `irreducible_set` gives the families that cannot hold together (an irreducible
infeasible set), deciding each trial with the same search and falling back to the closed-form
ray grid of ao_start when few families are left and the search's box becomes huge.
C2 is structural (it defines the master's ray) and is never dropped; a fixed master off C2 is
reported by the solver directly.
"""
from __future__ import annotations

from itertools import combinations

import numpy as np

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
    with np.errstate(all="ignore"):
        for size in range(1, max_size + 1):
            found = [list(s) for s in combinations(FAMILIES, size)
                     if feasible_without(p, scheme, frozenset(s))]
            if found:
                return found[0], found
    return [], []



def feasible_families(p: Params, scheme: str, on: frozenset[str],
                      max_nodes: int = 2_000) -> bool:
    """Is (P) with only the families `on` (plus C2) feasible? The branch and bound decides
    most cases in milliseconds, both ways; when its node budget runs out undecided (few
    families left make its box huge), the closed-form ray grid of ao_start decides."""
    from uav_insar_planner.solver.ao_start import find_start

    sc = rays.make_scenario(p, scheme, "bound", frozenset(FAMILIES) - on)
    with np.errstate(all="ignore"):
        res = certificate.search(sc, max_nodes=max_nodes, stop_when_feasible=True)
    if res.point is not None:
        return True
    if res.exhausted:
        return False
    return find_start(p, scheme, on | {"C2"}, first=True) is not None


def irreducible_set(p: Params, scheme: str) -> list[str]:
    """Deletion filter (Chinneck) from C11 down: drop each family in turn and keep it dropped
    while the rest stays infeasible. What is left cannot hold together, and each member is
    needed for that; from C11 down, so geometric families are kept when both a geometric and
    a communication explanation exist."""
    keep = set(FAMILIES)
    for family in sorted(FAMILIES, key=lambda n: -int(n[1:])):
        trial = keep - {family}
        if not feasible_families(p, scheme, frozenset(trial)):
            keep = trial
    return sorted(keep, key=lambda n: int(n[1:]))
