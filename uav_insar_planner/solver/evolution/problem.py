"""Problem (P) as a box-bounded continuous search for differential evolution.

Decision vector v: the master's altitude z_0 on its C2 line (x_0 = x_t - z_0 tan(theta_0),
so C2 holds by construction; absent for the fixed master, which sits at q0_fixed), then each
flown slave's (x_k, z_k). Every function takes v of shape (D,) or (D, S) (S candidates at
once, as scipy's vectorised constraints pass them) and broadcasts.

Objective: `exact` the fused sigma_h = (sum_k sigma_hk^-2)^(-1/2) (eqs. 13-15 with eq. 14's
Cramer-Rao phase error), `bound` Proposition 1's C r_0 / sqrt(sum_k b_perp,k^2).

Bounds and constraints are (P)'s Cartesian statement (solver/problem.py: cartesian_bounds,
cartesian_slacks, each slack g_i(v) >= 0 scaled to order one and tagged with its family
C1..C11); this module maps the decision vector onto positions and states the objective.
"""
from __future__ import annotations

import math

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.solver.problem import (
    Positions,
    cartesian_bounds,
    cartesian_slacks,
    make_problem,
    pair_terms,
)
from uav_insar_planner.swarm import MASTER

# An objective value for points where it is undefined (b_perp = 0: h_amb infinite).
WORSE_THAN_ANY = 1e12


class EvolutionProblem:
    """(P) for one scheme and objective over the decision vector of the module docstring."""

    def __init__(self, p: Params, scheme: str, objective: str):
        self.p, self.scheme, self.objective = p, scheme, objective
        self.problem = make_problem(p, scheme, objective)
        self.bounds = cartesian_bounds(self.problem)

    @property
    def empty(self) -> list[str]:
        """Families that no point can meet whatever the positions (the disk of C9-C11 is
        empty), or an empty box; [] when the search can start."""
        if any(self.problem.disk_r2[k] == -math.inf for k in self.problem.uavs):
            return ["C9"]
        return [] if all(lo <= hi for lo, hi in self.bounds) else ["C1", "C5", "C6"]

    def positions(self, v: np.ndarray) -> Positions:
        """UAV k -> (x_k, z_k), each of shape v.shape[1:]."""
        v = np.asarray(v, dtype=float)
        p = self.p
        if self.problem.fixed_master:
            shape = v.shape[1:]
            q = {MASTER: (np.full(shape, p.master_fixed[0]), np.full(shape, p.master_fixed[1]))}
            rest = v
        else:
            q = {MASTER: (model.master_x(v[0], p.x_t, p.theta0), v[0])}
            rest = v[1:]
        for i, k in enumerate(self.problem.slaves):
            q[k] = (rest[2 * i], rest[2 * i + 1])
        return q

    def formation(self, v: np.ndarray) -> np.ndarray:
        """(num_uavs, 2) rows (x_k, z_k) of one decision vector, NaN for UAVs not flown."""
        out = np.full((self.p.num_uavs, 2), np.nan)
        for k, (x, z) in self.positions(v).items():
            out[k] = (float(x), float(z))
        return out

    def objective_value(self, v: np.ndarray) -> np.ndarray:
        """sigma_h (exact) or Proposition 1's bound (bound) of every candidate in v."""
        p = self.p
        r0, pairs = pair_terms(self.problem, self.positions(v))
        if self.objective == "bound":
            bsq = sum(b * b for b, *_ in pairs.values())
            value = model.height_error_bound(p.wavelength, r0, p.theta0, bsq,
                                             model.worst_case_coherence(p), p.looks)
        else:
            # eq. 15 as (sum_k sigma_hk^-2)^(-1/2) (model.fused_height_error's closed form),
            # summed so that a pair with b_perp = 0 (sigma_hk infinite) adds nothing
            inv = 0.0
            for b, g_snr, g_rg, _ in pairs.values():
                g = model.coherence_total(g_rg, g_snr, p.coherence_other)
                h_amb = model.height_of_ambiguity(p.wavelength, r0, p.theta0, b)
                inv = inv + model.height_error(h_amb, model.phase_error_crb(g, p.looks)) ** -2.0
            with np.errstate(divide="ignore"):
                value = 1.0 / np.sqrt(inv)
        return np.where(np.isfinite(value), value, WORSE_THAN_ANY)

    def slacks(self, v: np.ndarray) -> np.ndarray:
        """Every scaled slack g_i(v) (>= 0 when met), shape (M,) + v.shape[1:]."""
        return np.stack([g for _, g in self.named_slacks(v)])

    def named_slacks(self, v: np.ndarray) -> list[tuple[str, np.ndarray]]:
        """(family, scaled slack) pairs: (P)'s Cartesian constraints (problem.cartesian_slacks)."""
        return [(name, np.broadcast_to(g, np.shape(v)[1:]).astype(float))
                for name, g in cartesian_slacks(self.problem, self.positions(v))]
