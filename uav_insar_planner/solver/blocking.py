"""Blocking constraint families: the names, and the one deletion filter both back ends use.

A scenario with no feasible point is explained by an irreducible infeasible set of constraint
families: they cannot hold together, and dropping any one of them makes the rest feasible.
Each back end supplies its own feasibility test for a set of families (the global back end its
branch and bound, the AO its start grid); the filter that turns the test into the set is here.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

ALL_FAMILIES = frozenset(f"C{i}" for i in range(1, 12))
# C2 is structural: it defines the master's ray, so it is never a relaxation (a fixed master
# off C2 is reported by the solver directly).
FAMILIES = ("C1", "C3", "C4", "C5", "C6", "C7", "C8", "C9", "C10", "C11")


def _number(family: str) -> int:
    return int(family[1:])


def irreducible_set(families: Iterable[str],
                    feasible: Callable[[frozenset[str]], bool]) -> list[str]:
    """Deletion filter (Chinneck): drop each family in turn and keep it dropped while the rest
    stays infeasible (`feasible(rest)` is False). Returns what is left, in the order C1..C11.

    Precondition: all of `families` together are infeasible. The filter runs from C11 down, so
    the geometric families (C1, C5, ...) are the ones kept when both a geometric and a
    communication explanation exist.
    """
    keep = set(families)
    for family in sorted(keep, key=lambda n: -_number(n)):
        trial = keep - {family}
        if not feasible(frozenset(trial)):
            keep = trial
    return sorted(keep, key=_number)
