"""The paper-faithful solver: Algorithm 2 (AO) over Algorithm 1 for (P.0) and the SCA for
(P.1)/(P.2), on CVXPY + Clarabel, minimising Proposition 1's bound.

One AO outer iteration solves (P.0) (master.py), then (P.1) and (P.2) (slave.py, both halves
I_a/I_b each), every sub-problem with its own UAV's P_com,k as a variable and C9-C11. It stops
when the bound's relative change is at most eps_2 = params.tolerance (eps_0 = eps_1 likewise).

Interpretations of the paper's listing:
- Gauss-Seidel order: each sub-problem sees the newest positions of the others. Algorithm 2's
  listing fixes the other blocks at iteration m-1 (Jacobi); through the coupling constraints
  C4, C6 and C8 two individually feasible Jacobi updates can combine into an infeasible
  formation, while the Gauss-Seidel order keeps every iterate feasible and the bound
  non-increasing.
- The start is the deterministic feasible formation of solver/start_grid.py (median feasible
  master altitude on its C2 line, slaves mid-way on their look-angle rays, U1 in I_a, U2 in
  I_b). Without one, the blocking families are the deletion filter of solver/blocking.py over
  that grid.
- objective "exact" is not what the paper optimises: the algorithm still minimises the bound
  and says so in the message (the certified exact solver is solver/global_opt/).

Schemes: "proposed"; "single-baseline" (benchmark 1: U0 and U1 only, bound with b_perp,2 = 0,
two-block AO); "fixed-master" (benchmark 2: q_0 = q0_fixed, (P.0) only allocates P_com,0);
"static-power" (benchmark 3: P_com,k[n] = E_max / (N delta_t), not a variable).
"""
from __future__ import annotations

import math

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.solver import blocking
from uav_insar_planner.solver.ao.closed_forms import formation_bound
from uav_insar_planner.solver.ao.master import MasterProblem
from uav_insar_planner.solver.ao.slave import SlaveProblem
from uav_insar_planner.solver.power import schedules
from uav_insar_planner.solver.problem import make_problem
from uav_insar_planner.solver.result import SolverResult
from uav_insar_planner.solver.start_grid import find_start

MAX_OUTER = 50


def blocking_families(p: Params, scheme: str) -> list[str]:
    """The deletion filter over C1..C11 with the start grid as the feasibility test: an
    irreducible set of families that is infeasible on the grid. C2 is only a family for the
    fixed master (elsewhere it defines the grid)."""
    families = blocking.FAMILIES + (("C2",) if scheme == "fixed-master" else ())
    return blocking.irreducible_set(
        families, lambda fam: find_start(p, scheme, fam, first=True) is not None)


def solve_ao(p: Params, scheme: str, objective: str) -> SolverResult:
    """Algorithm 2 for `scheme`; see the module docstring. Deterministic.

    C8 is per slave, h_amb,k >= h_amb^min rho^(k-1) with rho = `h_amb_ratio` (model.h_amb_min_of;
    rho = 1 is the paper's common limit); the start grid meets every slave's own rung."""
    pr = make_problem(p, scheme, objective)
    slaves = list(pr.slaves)
    note = ("objective 'exact' requested: paper-ao minimises Proposition 1's bound, as the paper "
            "does; " if objective == "exact" else "")
    if p.h_amb_ratio != 1.0:
        note += "C8 ladder " + ", ".join(f"h_amb,{k} >= {model.h_amb_min_of(p, k):.4g} m"
                                         for k in slaves) + "; "
    start = find_start(p, scheme)
    if start is None:
        blocking = blocking_families(p, scheme)
        return SolverResult(False, np.full((p.num_uavs, 2), np.nan),
                            np.zeros((p.num_uavs, p.num_slots)), 0,
                            blocking=blocking,
                            message=note + "no feasible start: constraint families "
                            + ", ".join(blocking) + " cannot hold together")
    formation = start.formation.copy()
    # Powers of a UAV whose sub-problem never moved it: the cheapest schedule at its position.
    p_com = schedules(p, formation, scheme)
    master = MasterProblem(pr)
    slave_problems = {k: SlaveProblem(pr, k, [0] + [j for j in slaves if j != k])
                      for k in slaves}
    inner: dict[str, list[int]] = {"P.0": []} | {f"P.{k}": [] for k in slaves}
    halves: dict[int, str] = {}
    bound = formation_bound(p, formation[0], formation, slaves)
    start_bound = bound
    status = "step limit"
    outer = 0
    for outer in range(1, MAX_OUTER + 1):
        if not pr.fixed_master or outer == 1:
            q0, power, steps, _ = master.run(formation)
            inner["P.0"].append(steps)
            if not pr.fixed_master:  # benchmark 2 keeps q0_fixed exactly
                formation[0] = q0
            if power is not None:
                p_com[0] = power
        for k in slaves:
            qk, power, steps, half = slave_problems[k].run(formation)
            inner[f"P.{k}"].append(steps)
            formation[k] = qk
            halves[k] = half
            if power is not None:
                p_com[k] = power
        new = formation_bound(p, formation[0], formation, slaves)
        done = abs(new - bound) <= p.tolerance * new
        bound = new
        if done:
            status = "converged"
            break
    counts = "; ".join(f"{name} SCA steps {v}" for name, v in inner.items())
    message = (f"{note}paper-ao: {outer} AO iterations ({status}, eps={p.tolerance:g}), bound "
               f"{start_bound:.6g} m at the start -> {bound:.6g} m; {counts}; halves "
               + ", ".join(f"U{k} {h}" for k, h in halves.items()))
    if not math.isfinite(bound):
        message += "; the bound is infinite (every b_perp is 0)"
    return SolverResult(True, formation, p_com, outer, message=message)
