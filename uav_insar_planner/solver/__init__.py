"""solve(params) -> Plan: run a back end, then check its answer independently.

Back ends: `global` (solver/global_opt/, certified optimum of the exact, bound or multilook
objective), `paper-ao` (solver/ao/, Algorithm 2 of the paper with SCA on CVXPY + Clarabel) and
`evolution` (solver/evolution/, seeded differential evolution, no certificate). They never
import each other; what they need (the station disk in power.py, the start grid, the deletion
filter in blocking.py, SolverResult) lives here in solver/.
"""
from __future__ import annotations

import time

import numpy as np

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import (
    OBJECTIVES,
    SCHEMES,
    SOLVERS,
    ParamError,
    Params,
    objective_problems,
)
from uav_insar_planner.plan import Plan


class SolverFailure(RuntimeError):
    """A back end raised on an allowed scenario: a bug, reported as one line naming the back
    end, the scheme and the exception instead of a traceback (the cause is to be fixed)."""


def _backend(name: str):
    if name == "global":
        from uav_insar_planner.solver.global_opt.optimum import solve_global

        return solve_global
    if name == "evolution":
        from uav_insar_planner.solver.evolution.algorithm import solve_evolution

        return solve_evolution
    from uav_insar_planner.solver.ao.algorithm2 import solve_ao

    return solve_ao


def solve(params: Params, scheme: str | None = None, objective: str | None = None,
          solver: str | None = None) -> Plan:
    """Solve problem (P) for `scheme` (default: params.scheme) and return a checked Plan.

    The plan's metrics, sigma_h, bound and constraint report come from the independent
    evaluator (`evaluate`), not from the back end. A back end's "feasible" answer whose
    formation fails that check is reported infeasible, naming the violated constraints.
    """
    scheme = scheme or params.scheme
    objective = objective or params.objective
    solver = solver or params.solver
    for field, value, allowed in (("scheme", scheme, SCHEMES), ("objective", objective, OBJECTIVES),
                                  ("solver", solver, SOLVERS)):
        if value not in allowed:
            raise ParamError([f"{field}: value {value!r} is not allowed; expected one of "
                              + ", ".join(allowed)])
    if problems := objective_problems(objective, solver):
        raise ParamError(problems)
    backend = _backend(solver)  # a lean install's ModuleNotFoundError is no solver bug
    start = time.perf_counter()
    try:
        result = backend(params, scheme, objective)
        elapsed = time.perf_counter() - start
        ev = evaluate(params, result.formation, result.p_com, scheme) if np.isfinite(
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
    metrics = ev.metrics if ev else {}
    if objective == "multilook" and ev is not None:
        from uav_insar_planner.multilook import plan_metrics

        # The multilook figures from the checker's coherences and h_amb, not the back end's.
        metrics = metrics | {"multilook": plan_metrics(ev.metrics["pairs"], params.looks)}
    return Plan(
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
        metrics=metrics,
        blocking_constraints=[] if feasible else blocking,
        lower_bound_m=result.lower_bound,
        optimality_gap=result.gap,
        certificate=result.certificate,
        message=message,
    )
