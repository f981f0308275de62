"""The paper-faithful solver: Algorithm 2 (AO) over Algorithm 1 for (P.0) and the SCA for
(P.1)/(P.2), on CVXPY + Clarabel, minimising Proposition 1's bound.

One AO outer iteration solves (P.0) (ao_master), then (P.1) and (P.2) (ao_slave, both halves
I_a/I_b each), every sub-problem with its own UAV's P_com,k as a variable and C9-C11. It stops
when the bound's relative change is at most eps_2 = params.tolerance (eps_0 = eps_1 likewise).

Interpretations (see docs/solver_ao.md):
- Gauss-Seidel order: each sub-problem sees the newest positions of the others. Algorithm 2's
  listing fixes the other blocks at iteration m-1 (Jacobi); through the coupling constraints
  C4, C6 and C8 two individually feasible Jacobi updates can combine into an infeasible
  formation, while the Gauss-Seidel order keeps every iterate feasible and the bound
  non-increasing.
- The start is the deterministic feasible formation of `ao_start` (median feasible master
  altitude on its C2 line, slaves mid-way on their look-angle rays, U1 in I_a, U2 in I_b).
- objective "exact" is not what the paper optimises: the algorithm still minimises the bound
  and says so in the message (the certified exact solver is solver/global_opt.py).

Schemes: "proposed"; "single-baseline" (benchmark 1: U0 and U1 only, bound with b_perp,2 = 0,
two-block AO); "fixed-master" (benchmark 2: q_0 = q0_fixed, (P.0) only allocates P_com,0);
"static-power" (benchmark 3: P_com,k[n] = E_max / (N delta_t), not a variable).
"""
from __future__ import annotations

import math

import numpy as np

from uav_insar_planner.evaluate import active_uavs
from uav_insar_planner.params import Params
from uav_insar_planner.solver.ao_common import bound_value
from uav_insar_planner.solver.ao_master import MasterProblem, _b_perp
from uav_insar_planner.solver.ao_slave import SlaveProblem
from uav_insar_planner.solver.ao_start import blocking_families, find_start
from uav_insar_planner.solver.power import schedules
from uav_insar_planner.solver.result import SolverResult

MAX_OUTER = 50


def formation_bound(p: Params, formation: np.ndarray, slaves: list[int]) -> float:
    """Proposition 1's bound of a formation whose master is on its C2 line."""
    r0 = float(np.hypot(formation[0, 0] - p.x_t, formation[0, 1]))
    return bound_value(p, r0, sum(_b_perp(p, formation[k]) ** 2 for k in slaves))


def solve_ao(p: Params, scheme: str, objective: str) -> SolverResult:
    """Algorithm 2 for `scheme`; see the module docstring. Deterministic."""
    slaves = [k for k in active_uavs(scheme) if k > 0]
    note = ("objective 'exact' requested: paper-ao minimises Proposition 1's bound, as the paper "
            "does; " if objective == "exact" else "")
    start = find_start(p, scheme)
    if start is None:
        blocking = blocking_families(p, scheme)
        return SolverResult(False, np.full((3, 2), np.nan), np.zeros((3, p.num_slots)), 0,
                            blocking=blocking,
                            message=note + "no feasible start: constraint families "
                            + ", ".join(blocking) + " cannot hold together")
    formation = start.formation.copy()
    # Powers of a UAV whose sub-problem never moved it: the cheapest schedule at its position.
    p_com = schedules(p, formation, scheme)
    master = MasterProblem(p, scheme, slaves)
    slave_problems = {k: SlaveProblem(p, scheme, k, [0] + [j for j in slaves if j != k])
                      for k in slaves}
    inner: dict[str, list[int]] = {"P.0": []} | {f"P.{k}": [] for k in slaves}
    halves: dict[int, str] = {}
    bound = formation_bound(p, formation, slaves)
    start_bound = bound
    status = "step limit"
    outer = 0
    for outer in range(1, MAX_OUTER + 1):
        if scheme != "fixed-master" or outer == 1:
            q0, power, steps, _ = master.run(formation)
            inner["P.0"].append(steps)
            if scheme != "fixed-master":  # benchmark 2 keeps q0_fixed exactly
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
        new = formation_bound(p, formation, slaves)
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
