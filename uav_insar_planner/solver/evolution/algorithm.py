"""The search: seeded differential evolution over the problem's box, then a local polish.

scipy.optimize.differential_evolution (Storn and Price's DE/best/1/bin, scipy's default) with
C1-C11 as one vectorised NonlinearConstraint g(v) >= 0. scipy then ranks candidates by
Lampinen's rules: a feasible one beats an infeasible one, two infeasible ones compare by their
total violation sum_i max(0, -g_i), two feasible ones by the objective. The whole population
is evaluated in one numpy call per generation (`vectorized`, `updating="deferred"`).

DE's optimum sits on active constraints (C8 binds at the optimum of (P)) that the population
only approaches; SLSQP from DE's best point then moves onto them. Its point is taken only
when every slack is >= -POLISH_TOL (scaled slacks, far inside the checker's 1e-6) and the
objective is lower, so the answer is never worse than DE's. Same seed, same answer.
"""
from __future__ import annotations

import warnings

import numpy as np
from scipy.optimize import NonlinearConstraint, differential_evolution, minimize

from uav_insar_planner.params import Params
from uav_insar_planner.solver.evolution.problem import EvolutionProblem
from uav_insar_planner.solver.evolution.result import Outcome, to_solver_result
from uav_insar_planner.solver.result import SolverResult

SEED = 0
POPSIZE = 20  # candidates per decision variable
MAX_GENERATIONS = 1000
TOL = 1e-9  # relative spread of the population's objective at which DE stops
POLISH_TOL = 1e-10


def search(problem: EvolutionProblem, seed: int = SEED) -> Outcome:
    """Differential evolution then the polish (module docstring)."""
    constraint = NonlinearConstraint(problem.slacks, 0.0, np.inf)
    with warnings.catch_warnings():
        # scipy warns when the constrained DE ends with an infeasible best: reported instead
        warnings.simplefilter("ignore", UserWarning)
        de = differential_evolution(
            problem.objective_value, problem.bounds, constraints=constraint,
            popsize=POPSIZE, maxiter=MAX_GENERATIONS, tol=TOL, rng=np.random.default_rng(seed),
            polish=False, vectorized=True, updating="deferred")
    x = np.asarray(de.x, dtype=float)
    feasible = bool(np.min(problem.slacks(x)) >= 0.0)
    polished = False
    if feasible:
        better = _polish(problem, x)
        polished = better is not None
        x = better if polished else x
    return Outcome(x, feasible, int(de.nit), int(de.nfev), polished)


def _polish(problem: EvolutionProblem, x: np.ndarray) -> np.ndarray | None:
    """SLSQP from x within the box; its point if it meets every slack and is better."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        res = minimize(lambda v: float(problem.objective_value(v)), x, method="SLSQP",
                       bounds=problem.bounds, options={"maxiter": 200, "ftol": 1e-14},
                       constraints=[{"type": "ineq", "fun": problem.slacks}])
    y = np.clip(np.asarray(res.x, dtype=float), *np.array(problem.bounds).T)
    ok = np.all(np.isfinite(y)) and float(np.min(problem.slacks(y))) >= -POLISH_TOL
    if ok and float(problem.objective_value(y)) < float(problem.objective_value(x)):
        return y
    return None


def solve_evolution(p: Params, scheme: str, objective: str, seed: int = SEED) -> SolverResult:
    """The evolution back end: (P) for `scheme` and `objective` (exact or bound) by seeded
    differential evolution; no certificate (lower_bound NaN). Deterministic for a seed. The
    tomography objective: solver/evolution/tomography.py."""
    if objective == "tomography":  # the relaxation and its bound, then the geometry
        from uav_insar_planner.solver.evolution.tomography import solve_tomography

        return solve_tomography(p, scheme)
    problem = EvolutionProblem(p, scheme, objective)
    if blocked := problem.empty:
        return to_solver_result(problem, None, seed, blocked)
    return to_solver_result(problem, search(problem, seed), seed, [])
