"""(P.0) and Algorithm 1: the master's position and power for fixed slaves, by SCA.

Convex approximation (P.0~) around q_0^(i), built once per AO run with CVXPY Parameters (DPP),
so each SCA step only updates numbers:

  min  K r_0 / sqrt(b_perp,1^2 + b_perp,2^2)     (Proposition 1; b_perp,k fixed by the slaves,
                                                  eq. 16, so the objective is linear in z_0)
  s.t. C1   z_min <= z_0 <= z_max
       C2   x_0 = x_t - z_0 tan(theta_0)
       C4~  2 q_0^T (q_0^(i) - q_k) - ||q_0^(i)||^2 + ||q_k||^2 >= d_min^2   (eq. 18)
       C5   Theta_3dB r_0 / cos(theta_0) >= S_min   (linear on the C2 line)
       C6   r_0 <= r_0,max(r_k)   (gamma_SNR,k decreases in r_0: exact, see closed_forms)
       C8   lambda r_0 sin(theta_0) >= h_amb,k^min b_perp,k   (h_amb,k^min, the slave's rung
            of h_amb_ratio's ladder, model.h_amb_min_of)
       C9-C11 with P_com,0 a variable (comm_constraints).
With r_0 = z_0 / cos(theta_0) on the C2 line. Benchmark 2 pins z_0 (and x_0) to q0_fixed and
uses the same programme only to allocate P_com,0.
"""
from __future__ import annotations

import math

import cvxpy as cp
import numpy as np

from uav_insar_planner import model
from uav_insar_planner.solver.ao.closed_forms import (
    b_perp_on_c2,
    formation_bound,
    master_range_max,
)
from uav_insar_planner.solver.ao.comm_constraints import comm_constraints
from uav_insar_planner.solver.ao.convex import MAX_INNER, solve_convex
from uav_insar_planner.solver.problem import Problem


class MasterProblem:
    """(P.0~) for the problem's slaves, rebuilt only by Parameter updates."""

    def __init__(self, pr: Problem):
        p = pr.p
        self.p, self.slaves = p, list(pr.slaves)
        self.q = cp.Variable(2, name="q0")
        x0, z0 = self.q[0], self.q[1]
        cos0 = math.cos(p.theta0)
        r0 = z0 / cos0
        self.scale = cp.Parameter(nonneg=True, name="K_over_sqrt_bperp_sq")
        self.r0_max = cp.Parameter(nonneg=True, name="r0_max")
        self.r0_min = cp.Parameter(nonneg=True, name="r0_min_c8")
        self.c4_lin = {k: cp.Parameter(2, name=f"c4_lin_{k}") for k in self.slaves}
        self.c4_const = {k: cp.Parameter(name=f"c4_const_{k}") for k in self.slaves}
        self.pin = cp.Parameter(2, name="q0_fixed")
        cons = [z0 >= p.z_min, z0 <= p.z_max,                                          # C1
                x0 == p.x_t - math.tan(p.theta0) * z0,                                 # C2
                p.beamwidth * r0 / cos0 >= p.swath_min,                                # C5
                r0 <= self.r0_max,                                                     # C6
                r0 >= self.r0_min]                                                     # C8
        cons += [self.c4_lin[k] @ self.q + self.c4_const[k] >= p.d_min**2              # C4~
                 for k in self.slaves]
        if pr.fixed_master:
            cons.append(self.q == self.pin)
        self.power, comm = comm_constraints(p, 0, self.q, pr.scheme)
        self.problem = cp.Problem(cp.Minimize(self.scale * r0), cons + comm)

    def _set(self, q0_ref: np.ndarray, formation: np.ndarray) -> None:
        p = self.p
        b = [b_perp_on_c2(p, formation[k]) for k in self.slaves]
        k_bound = model.bound_constant(p.wavelength, p.theta0, model.worst_case_coherence(p),
                                       p.looks)
        self.scale.value = k_bound / math.sqrt(max(sum(v * v for v in b), 1e-300))
        ranges = [float(np.hypot(formation[k, 0] - p.x_t, formation[k, 1])) for k in self.slaves]
        self.r0_max.value = master_range_max(p, ranges)
        # C8 per slave: r_0 >= h_amb,k^min b_perp,k / (lambda sin(theta_0)), each slave
        # against its own rung
        self.r0_min.value = max(model.master_range_min_c8(p, bk, k)
                                for k, bk in zip(self.slaves, b, strict=True))
        for k in self.slaves:
            qk = formation[k]
            self.c4_lin[k].value = 2.0 * (q0_ref - qk)
            self.c4_const[k].value = float(qk @ qk - q0_ref @ q0_ref)
        self.pin.value = formation[0]

    def run(self, formation: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, int, str]:
        """Algorithm 1 from the formation's master: (q_0, P_com,0, SCA steps, status).

        Stops when the bound's relative change is below eps_0 = params.tolerance. A failed
        convex solve keeps the last feasible point and says so in the status."""
        p = self.p
        q = formation[0].copy()
        power = None
        prev = formation_bound(p, q, formation, self.slaves)
        for step in range(1, MAX_INNER + 1):
            self._set(q, formation)
            if not solve_convex(self.problem):
                return q, power, step, str(self.problem.status)
            q = np.asarray(self.q.value, dtype=float)
            power = np.asarray(self.power.value, dtype=float)
            cur = formation_bound(p, q, formation, self.slaves)
            if abs(cur - prev) <= p.tolerance * cur:
                return q, power, step, "converged"
            prev = cur
        return q, power, MAX_INNER, "step limit"
