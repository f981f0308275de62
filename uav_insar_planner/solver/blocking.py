"""Which constraint families block an infeasible scenario.

`blocking_sets` gives the smallest family sets whose removal alone makes the scenario feasible
(which relaxations would help), proven with the branch and bound of certificate.py in
feasibility mode. The families that cannot hold together (an irreducible infeasible set) come
from `ao_start.blocking_families`, whose closed-form ray intervals on a grid stay fast when
few families are left, where this search's box becomes huge.
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

