"""One convex sub-problem solve with Clarabel, and when its point may be taken as an SCA step.

Shared by (P.0) (master.py) and (P.1)/(P.2) (slave.py).
"""
from __future__ import annotations

import warnings

import cvxpy as cp
import numpy as np

SOLVER_OPTS = {"solver": cp.CLARABEL}
MAX_INNER = 50  # SCA steps at most per sub-problem run (Algorithm 1 and its slave twin)
INACCURATE_MAX_VIOLATION = 1e-7  # SI units of each constraint; far below the checker's margin


def solve_convex(problem: cp.Problem) -> bool:
    """Solve with Clarabel; True when the point may be taken as an SCA step: a certified optimum,
    or an "inaccurate" one whose constraints all hold to INACCURATE_MAX_VIOLATION. Otherwise the
    caller keeps its last feasible point (so cvxpy's "may be inaccurate" warning is not shown)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        try:
            problem.solve(**SOLVER_OPTS)
        except cp.SolverError:
            return False
    if problem.status == cp.OPTIMAL:
        return True
    return problem.status == cp.OPTIMAL_INACCURATE and all(
        float(np.max(c.violation())) <= INACCURATE_MAX_VIOLATION for c in problem.constraints)
