"""The evolution back end's answer as a SolverResult: the formation, the cheapest power
schedule per position (solver/power.py, C10 tight), and a message that says what was run and
that there is no certificate (lower_bound and gap NaN).

An infeasible answer is DE's conclusion, not a proof: the families named are those whose
slacks are negative at the least-violating point it found (or the families that empty the
search box or the station disk before any search).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from uav_insar_planner.solver.power import schedules
from uav_insar_planner.solver.result import SolverResult

if TYPE_CHECKING:
    from uav_insar_planner.solver.evolution.problem import EvolutionProblem

NO_CERTIFICATE = "no certificate: a metaheuristic (lower bound NaN)"


@dataclass
class Outcome:
    """What the search found: the best vector, whether it meets every slack, DE's
    generations and evaluations, and whether the polish improved it."""

    x: np.ndarray
    feasible: bool
    generations: int
    evaluations: int
    polished: bool


def violated_families(problem: EvolutionProblem, x: np.ndarray) -> list[str]:
    """The constraint families with a negative slack at x, in C1..C11 order."""
    bad = {name for name, g in problem.named_slacks(x) if float(np.min(g)) < 0.0}
    return sorted(bad, key=lambda n: int(n[1:]))


def to_solver_result(problem: EvolutionProblem, outcome: Outcome | None, seed: int,
                     blocked: list[str]) -> SolverResult:
    """SolverResult of a search `outcome`, or of no search when `blocked` names families
    that empty the box or the station disk."""
    p, scheme = problem.p, problem.scheme
    empty = np.full((p.num_uavs, 2), np.nan)
    if outcome is None:
        return SolverResult(False, empty, np.zeros((p.num_uavs, p.num_slots)), 0,
                            blocking=blocked, message="evolution: no point can meet "
                            + ", ".join(blocked) + "; " + NO_CERTIFICATE)
    formation = problem.formation(outcome.x)
    run = (f"evolution: differential evolution (scipy), seed {seed}, {outcome.generations} "
           f"generations, {outcome.evaluations} evaluations"
           + (", SLSQP polish taken" if outcome.polished else ", polish not taken"))
    if not outcome.feasible:
        families = violated_families(problem, outcome.x)
        return SolverResult(False, empty, np.zeros((p.num_uavs, p.num_slots)),
                            outcome.generations, blocking=families,
                            message=f"{run}; no feasible point found (least violation breaks "
                            + ", ".join(families) + "; not a proof); " + NO_CERTIFICATE)
    return SolverResult(True, formation, schedules(p, formation, scheme), outcome.generations,
                        message=f"{run}; {NO_CERTIFICATE}")
