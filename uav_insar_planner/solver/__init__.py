"""solve(params) -> Plan: run a back end, then check its answer independently.

Back ends, each declared once in `param_specs.science.BACKENDS` (name, objectives, certified or not,
where its solve function is): `global` (solver/global_opt/, certified optimum of the exact,
bound or multilook objective), `paper-ao` (solver/ao/, Algorithm 2 of the paper with SCA on
CVXPY + Clarabel) and `evolution` (solver/evolution/, seeded differential evolution, no
certificate). They never import each other; what they need (the statement of (P) in
problem.py, the station disk in power.py, the start grid, the deletion filter in blocking.py,
SolverResult) lives here in solver/.

With nav_error_m = e > 0 (robust.py) the back end solves the certified tightening of (P); the
plan then carries its certified worst-case sigma_h over the error disks
(`Plan.sigma_h_worst_m`), the worst-case constraint slacks (`Plan.robust_constraints`) and the
lower bound and gap of the worst-case problem. At e = 0 nothing of that path runs.
"""
from __future__ import annotations

import importlib
import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.param_specs.science import BACKEND_BY_NAME
from uav_insar_planner.params import (
    OBJECTIVES,
    SCHEMES,
    SOLVERS,
    ParamError,
    Params,
    nav_error_problems,
    objective_problems,
)
from uav_insar_planner.plan import Plan
from uav_insar_planner.solver import robust
from uav_insar_planner.solver.result import SolverResult


class SolverFailure(RuntimeError):
    """A back end raised on an allowed scenario: a bug, reported as one line naming the back
    end, the scheme and the exception instead of a traceback (the cause is to be fixed)."""


def backend(name: str) -> Callable[[Params, str, str], SolverResult]:
    """The solve function of the back end declared as `name` in BACKENDS, imported now."""
    module, _, function = BACKEND_BY_NAME[name].entry.partition(":")
    return getattr(importlib.import_module(module), function)


def solve(params: Params, scheme: str | None = None, objective: str | None = None,
          solver: str | None = None, *, warm_start: object | None = None) -> Plan:
    """Solve problem (P) for `scheme` (default: params.scheme) and return a checked Plan.

    The plan's metrics, sigma_h, bound and constraint report come from the independent
    evaluator (`evaluate`), not from the back end. A back end's "feasible" answer whose
    formation fails that check is reported infeasible, naming the violated constraints.

    `warm_start`: the state a sweep hands from one solve to the next (`new_warm_start`), passed
    to a back end that takes it (BACKENDS' warm_start) for a nominal solve, else unused.
    """
    scheme = scheme or params.scheme
    objective = objective or params.objective
    solver = solver or params.solver
    for field, value, allowed in (("scheme", scheme, SCHEMES), ("objective", objective, OBJECTIVES),
                                  ("solver", solver, SOLVERS)):
        if value not in allowed:
            raise ParamError([f"{field}: value {value!r} is not allowed; expected one of "
                              + ", ".join(allowed)])
    if problems := (objective_problems(objective, solver)
                    + nav_error_problems(params.nav_error_m, solver)):
        raise ParamError(problems)
    run = backend(solver)  # a lean install's ModuleNotFoundError is no solver bug
    start = time.perf_counter()
    answer = None
    try:
        if params.nav_error_m > 0.0:
            answer = robust.solve(params, scheme, objective, run)
            result = answer.result
        elif warm_start is not None and BACKEND_BY_NAME[solver].warm_start:
            result = run(params, scheme, objective, warm_start=warm_start)
        else:
            result = run(params, scheme, objective)
        elapsed = time.perf_counter() - start
        ev = evaluate(params, result.formation, result.p_com, scheme, objective) if np.isfinite(
            result.formation[0, 0]) else None
    except Exception as exc:  # any bug becomes one clear line, not a traceback
        text = " ".join(str(exc).split())[:120]
        raise SolverFailure(f"solver {solver} failed on scheme {scheme}, objective "
                            f"{objective}: {type(exc).__name__}: {text} (a bug: please "
                            "report it with the parameters)") from exc
    feasible = result.feasible and ev is not None and ev.feasible
    blocking = list(result.blocking)
    message = result.message
    if result.feasible and ev is not None and not ev.feasible:
        blocking = ev.violated
        message = (message + "; " if message else "") + "independent check failed: " + ", ".join(
            f"{n} (slack {ev.constraints[n].slack:.3g})" for n in ev.violated)
    plan = Plan(
        feasible=feasible,
        scheme=scheme,
        objective=objective,
        solver=solver,
        formation=np.asarray(result.formation, dtype=float),
        p_com_w=np.asarray(result.p_com, dtype=float),
        sigma_h_m=ev.sigma_h if ev else float("nan"),
        sigma_h_bound_m=ev.sigma_h_bound if ev else float("nan"),
        iterations=result.iterations,
        solve_time_s=elapsed,
        constraints=ev.constraints if ev else {},
        metrics={**ev.metrics, **result.metrics} if ev else {},
        blocking_constraints=[] if feasible else blocking,
        lower_bound_m=result.lower_bound,
        optimality_gap=result.gap,
        certificate=result.certificate,
        message=message,
        sigma_h_worst_m=ev.sigma_h if ev else float("nan"),
    )
    return plan if answer is None else robust_plan(plan, params, answer)


def new_warm_start(solver: str) -> object | None:
    """A fresh warm start for a sequence of solves with back end `solver` (None when it takes
    none); it is not shared between schemes or objectives."""
    declared = BACKEND_BY_NAME.get(solver)  # an unknown name is solve's one-line error
    module, _, cls = declared.warm_start.partition(":") if declared else ("", "", "")
    return getattr(importlib.import_module(module), cls)() if module else None


def robust_plan(plan: Plan, params: Params, answer: robust.RobustAnswer) -> Plan:
    """`plan` with the worst case of robust.solve's answer and the worst-case slacks it
    computed for this plan over the error disks (`RobustAnswer.held`, worst_case.robust_slacks,
    not run again here); a plan failing that check is reported infeasible."""
    plan = replace(plan, nav_error_m=params.nav_error_m, worst_lower_bound_m=answer.lower_bound,
                   worst_certificate=answer.certificate)
    if answer.worst is None or not plan.feasible:
        return replace(plan, sigma_h_worst_m=float("nan"))
    held = answer.held
    plan = replace(plan, sigma_h_worst_m=answer.worst.upper, robust_constraints=held,
                   worst_gap=(answer.worst.upper - answer.lower_bound) / answer.worst.upper)
    if answer.worst.upper == float("inf"):
        plan.message = (plan.message + "; " if plan.message else "") + (
            "the worst case is unbounded: the error may take a pair's whole b_perp")
    failed = [n for n, c in held.items() if not c.ok]
    if failed:
        plan = replace(plan, feasible=False, blocking_constraints=failed, message=(
            plan.message + "; " if plan.message else "") + "worst-case check failed: " + ", ".join(
            f"{n} (slack {held[n].slack:.3g})" for n in failed))
    return plan
