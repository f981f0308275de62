"""(P.1)/(P.2): a slave's position and power for fixed master and other slave, by SCA over the
two halves I_a = {theta_k <= theta_0} and I_b = {theta_k >= theta_0}.

For fixed q_0 and q_j, minimising Proposition 1's bound is maximising b_perp,k (eq. 16), which is
linear on each half: cos(theta_0) (tan(theta_0) z_k - (x_t - x_k)) on I_a and its negative on
I_b. The convex approximation (P.k.a~) / (P.k.b~) around q_k^(j), built once per AO run (DPP):

  max  b_perp,k
  s.t. the half:  x_t - x_k <= tan(theta_0) z_k  (I_a)   or  >=  (I_b)
       C1   z_min <= z_k <= z_max
       C3   tan(theta_min) z_k <= x_t - x_k <= tan(theta_max) z_k
       C4~~ 2 q_k^T (q_k^(j) - q_i) - ||q_k^(j)||^2 + ||q_i||^2 >= d_min^2, i = master, other slave
       C5~  r_k^2(q^(j)) + grad r_k^2(q^(j))^T (q_k - q^(j)) >= S_min z_k / Theta_3dB   (eq. 20)
       C6   ||q_k - (x_t, 0)|| <= r_k,max(r_0)   (exact, model.slave_range_max)
       C7a  alpha_a z_k <= x_t - x_k  (I_a)  /  C7b  x_t - x_k <= alpha_b z_k  (I_b)  (Prop. 2)
       C8   b_perp,k <= lambda r_0 sin(theta_0) / h_amb,k^min  (the slave's rung of
            h_amb_ratio's ladder, model.h_amb_min_of)
       C9-C11 with P_com,k a variable (comm_constraints).
Both halves are run to convergence (eps_1 = params.tolerance) and the larger b_perp,k is kept.
"""
from __future__ import annotations

import math

import cvxpy as cp
import numpy as np

from uav_insar_planner import model
from uav_insar_planner.solver.ao.closed_forms import b_perp_on_c2, c7_slopes
from uav_insar_planner.solver.ao.comm_constraints import comm_constraints
from uav_insar_planner.solver.ao.convex import MAX_INNER, solve_convex
from uav_insar_planner.solver.problem import Problem


class SlaveProblem:
    """(P.k.a~) and (P.k.b~) for slave k, sharing one set of Parameters."""

    def __init__(self, pr: Problem, k: int, others: list[int]):
        self.p, self.k, self.others = pr.p, k, others
        self.c4_lin = {i: cp.Parameter(2, name=f"c4_lin_{k}{i}") for i in others}
        self.c4_const = {i: cp.Parameter(name=f"c4_const_{k}{i}") for i in others}
        self.c5_grad = cp.Parameter(2, name=f"c5_grad_{k}")
        self.c5_const = cp.Parameter(name=f"c5_const_{k}")
        self.r_max = cp.Parameter(nonneg=True, name=f"r_max_{k}")
        self.b_max = cp.Parameter(nonneg=True, name=f"b_max_{k}")
        self.halves = {h: self._build(pr.scheme, h) for h in ("a", "b")}

    def _build(self, scheme: str, half: str):
        p = self.p
        q = cp.Variable(2, name=f"q{self.k}{half}")
        x, z = q[0], q[1]
        across = p.x_t - x                      # x_t - x_k = z_k tan(theta_k)
        t0 = math.tan(p.theta0)
        sign = 1.0 if half == "a" else -1.0
        b_perp = sign * (t0 * z - across) * math.cos(p.theta0)
        alpha_a, alpha_b = c7_slopes(p)
        cons = [sign * (t0 * z - across) >= 0,                                       # I_a / I_b
                z >= p.z_min, z <= p.z_max,                                          # C1
                # C3 as cos(theta) (x_t - x) vs sin(theta) z: tan(90 deg) = 1.6e16 would
                # wreck the conditioning (Clarabel then missed C8 by 7e-5 m)
                math.cos(p.theta_min) * across >= math.sin(p.theta_min) * z,         # C3
                math.cos(p.theta_max) * across <= math.sin(p.theta_max) * z,
                self.c5_grad @ q + self.c5_const >= p.swath_min / p.beamwidth * z,   # C5~
                cp.norm(q - np.array([p.x_t, 0.0])) <= self.r_max,                   # C6
                b_perp <= self.b_max]                                                # C8
        cons += [self.c4_lin[i] @ q + self.c4_const[i] >= p.d_min**2                 # C4~~
                 for i in self.others]
        if half == "a" and alpha_a is not None:
            cons.append(alpha_a * z <= across)                                       # C7a
        if half == "b" and alpha_b is not None:
            cons.append(across <= alpha_b * z)                                       # C7b
        power, comm = comm_constraints(p, self.k, q, scheme)
        return q, power, cp.Problem(cp.Maximize(b_perp), cons + comm)

    def _set(self, q_ref: np.ndarray, formation: np.ndarray) -> None:
        p = self.p
        for i in self.others:
            qi = formation[i]
            self.c4_lin[i].value = 2.0 * (q_ref - qi)
            self.c4_const[i].value = float(qi @ qi - q_ref @ q_ref)
        grad = 2.0 * np.array([q_ref[0] - p.x_t, q_ref[1]])
        r2 = (q_ref[0] - p.x_t) ** 2 + q_ref[1] ** 2
        self.c5_grad.value = grad
        self.c5_const.value = float(r2 - grad @ q_ref)
        r0 = float(np.hypot(formation[0, 0] - p.x_t, formation[0, 1]))
        self.r_max.value = max(float(model.slave_range_max(p, r0)), 0.0)
        self.b_max.value = model.baseline_max(p, r0, self.k)

    def _sca(self, half: str, formation: np.ndarray):
        """SCA on one half from the current slave position: (q, P, b_perp, steps) or None."""
        q_var, power, problem = self.halves[half]
        q = formation[self.k].copy()
        prev, out = b_perp_on_c2(self.p, q), None
        for step in range(1, MAX_INNER + 1):
            self._set(q, formation)
            if not solve_convex(problem):
                break
            q = np.asarray(q_var.value, dtype=float)
            cur = b_perp_on_c2(self.p, q)
            out = (q, np.asarray(power.value, dtype=float), cur, step)
            # b_perp's relative change is the bound's for fixed q_0, q_j (eps_1 = eps_0)
            if abs(cur - prev) <= self.p.tolerance * max(cur, 1e-300):
                break
            prev = cur
        return out

    def run(self, formation: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, int, str]:
        """Both halves; the one with the larger b_perp,k (smaller bound) is kept.
        Returns (q_k, P_com,k, SCA steps over both halves, which half or 'unchanged')."""
        results = {h: self._sca(h, formation) for h in ("a", "b")}
        steps = sum(r[3] for r in results.values() if r is not None)
        done = [(r[2], h, r) for h, r in results.items() if r is not None]
        if not done:
            return formation[self.k].copy(), None, steps, "unchanged"
        top = max(d[0] for d in done)
        # halves tied to solver precision: stay on the side the slave is on (deterministic)
        start = formation[self.k]
        here = "a" if self.p.x_t - start[0] <= math.tan(self.p.theta0) * start[1] else "b"
        _, half, best = max(done, key=lambda d: (d[0] >= top * (1 - 1e-7), d[1] == here, d[0]))
        return best[0], best[1], steps, f"I_{half}"
