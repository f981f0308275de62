"""Problem (P) as a box-bounded continuous search for differential evolution.

Decision vector v: the master's altitude z_0 on its C2 line (x_0 = x_t - z_0 tan(theta_0),
so C2 holds by construction; absent for the fixed master, which sits at q0_fixed), then each
flown slave's (x_k, z_k). Every function takes v of shape (D,) or (D, S) (S candidates at
once, as scipy's vectorised constraints pass them) and broadcasts.

Objective: `exact` the fused sigma_h = (sum_k sigma_hk^-2)^(-1/2) (eqs. 13-15 with eq. 14's
Cramer-Rao phase error), `bound` Proposition 1's C r_0 / sqrt(sum_k b_perp,k^2).

Constraints, each a slack g_i(v) >= 0 scaled to order one (lengths by a length of their own
family, coherences as they are), all from model.py:
C1 z_min <= z_k <= z_max; C3 theta_min <= theta_k <= theta_max; C4 ||q_i - q_j|| >= d_min;
C5 Theta_3dB r_k / cos(theta_k) >= S_min; C6 gamma_SNR,k >= gamma_SNR^min (eq. 7);
C7 gamma_Rg,k >= gamma_Rg^min (eq. 10); C8 b_perp,k <= b_max,k(r_0) (model.baseline_max, the
same as h_amb,k >= h_amb,k^min, slave k's rung); C9-C11 with the cheapest power schedule,
exactly the disk
rho_k^2 <= power.station_radius_sq (rho_k the x-z distance to the station).

Bounds (valid for every feasible point, so the box loses nothing): z_0 from C1, C5 (r_0 >=
S_min cos(theta_0)/Theta_3dB) and C6 with a slave on the target (r_0^3 <= gamma_m
(1/gamma_SNR^min^2 - 1)); a slave within R = model.slave_range_max at the least r_0, at a look
angle in [theta_min, theta_max] (C3), so z_k <= R cos(theta_min) and
x_t - R sin(theta_max) <= x_k <= x_t - z_min tan(theta_min).
"""
from __future__ import annotations

import math

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.schemes import active_uavs, slave_uavs
from uav_insar_planner.solver.power import station_radius_sq
from uav_insar_planner.swarm import MASTER

# An objective value for points where it is undefined (b_perp = 0: h_amb infinite).
WORSE_THAN_ANY = 1e12


class EvolutionProblem:
    """(P) for one scheme and objective over the decision vector of the module docstring."""

    def __init__(self, p: Params, scheme: str, objective: str):
        self.p, self.scheme, self.objective = p, scheme, objective
        self.slaves = slave_uavs(scheme, p.num_uavs)
        self.uavs = active_uavs(scheme, p.num_uavs)
        self.fixed_master = scheme == "fixed-master"
        self.gm = model.gamma_m(p)
        self.radius_sq = {k: station_radius_sq(p, k, scheme) for k in self.uavs}
        self.k_bound = model.bound_constant(p.wavelength, p.theta0,
                                            model.worst_case_coherence(p), p.looks)
        self.bounds = self._bounds()

    @property
    def empty(self) -> list[str]:
        """Families that no point can meet whatever the positions (the disk of C9-C11 is
        empty), or an empty box; [] when the search can start."""
        if any(r == -math.inf for r in self.radius_sq.values()):
            return ["C9"]
        return [] if all(lo <= hi for lo, hi in self.bounds) else ["C1", "C5", "C6"]

    def _bounds(self) -> list[tuple[float, float]]:
        p = self.p
        c0 = math.cos(p.theta0)
        r0_lo = max(p.z_min / c0, p.swath_min * c0 / p.beamwidth)
        r0_hi = (self.gm * (1.0 / p.coherence_snr_min**2 - 1.0)) ** (1.0 / 3.0)
        out = [] if self.fixed_master else [(r0_lo * c0, min(p.z_max, r0_hi * c0))]
        r0_least = math.hypot(*(np.subtract(p.master_fixed, (p.x_t, 0.0)))) \
            if self.fixed_master else r0_lo
        reach = float(model.slave_range_max(p, r0_least))
        z_hi = min(p.z_max, reach * math.cos(p.theta_min))
        x_lo, x_hi = p.x_t - reach * math.sin(p.theta_max), p.x_t - p.z_min * math.tan(p.theta_min)
        for _ in self.slaves:
            out += [(x_lo, x_hi), (p.z_min, z_hi)]
        return out

    def positions(self, v: np.ndarray) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """UAV k -> (x_k, z_k), each of shape v.shape[1:]."""
        v = np.asarray(v, dtype=float)
        p = self.p
        if self.fixed_master:
            shape = v.shape[1:]
            q = {MASTER: (np.full(shape, p.master_fixed[0]), np.full(shape, p.master_fixed[1]))}
            rest = v
        else:
            q = {MASTER: (model.master_x(v[0], p.x_t, p.theta0), v[0])}
            rest = v[1:]
        for i, k in enumerate(self.slaves):
            q[k] = (rest[2 * i], rest[2 * i + 1])
        return q

    def formation(self, v: np.ndarray) -> np.ndarray:
        """(num_uavs, 2) rows (x_k, z_k) of one decision vector, NaN for UAVs not flown."""
        out = np.full((self.p.num_uavs, 2), np.nan)
        for k, (x, z) in self.positions(v).items():
            out[k] = (float(x), float(z))
        return out

    def _pairs(self, q):
        """Per slave: b_perp,k, gamma_SNR,k, gamma_Rg,k and theta_k (eqs. 3, 7-11)."""
        p = self.p
        x0, z0 = q[MASTER]
        r0 = model.slant_range(x0, z0, p.x_t)
        bp = p.radar_bandwidth_hz / p.center_frequency_hz
        out = {}
        for k in self.slaves:
            xk, zk = q[k]
            theta = model.look_angle(xk, zk, p.x_t)
            rk = model.slant_range(xk, zk, p.x_t)
            out[k] = (model.perpendicular_baseline(x0, z0, xk, zk, p.theta0),
                      model.coherence_snr_at_ranges(r0, rk, self.gm),
                      model.coherence_baseline(model.chi(p.theta0, theta), bp), theta)
        return r0, out

    def objective_value(self, v: np.ndarray) -> np.ndarray:
        """sigma_h (exact) or Proposition 1's bound (bound) of every candidate in v."""
        p = self.p
        r0, pairs = self._pairs(self.positions(v))
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
        """(family, scaled slack) pairs: C1-C11 as in the module docstring."""
        p = self.p
        q = self.positions(v)
        r0, pairs = self._pairs(q)
        out: list[tuple[str, np.ndarray]] = []
        zscale = max(p.z_max - p.z_min, 1.0)
        for k in self.uavs:
            x, z = q[k]
            out += [("C1", (z - p.z_min) / zscale), ("C1", (p.z_max - z) / zscale)]
            theta = p.theta0 if k == MASTER else pairs[k][3]
            r = model.slant_range(x, z, p.x_t)
            out.append(("C5", (model.swath_width(r, theta, p.beamwidth) - p.swath_min)
                        / max(p.swath_min, 1.0)))
            rad = self.radius_sq[k]
            if math.isfinite(rad):
                rho_sq = (x - p.ground_station[0]) ** 2 + (z - p.ground_station[2]) ** 2
                out.append(("C10", (rad - rho_sq) / max(abs(rad), 1.0)))
        for k, (b, g_snr, g_rg, theta) in pairs.items():
            b_max = model.baseline_max(p, r0, k)  # slave k's own C8 rung (h_amb_ratio)
            out += [("C3", theta - p.theta_min), ("C3", p.theta_max - theta),
                    ("C6", g_snr - p.coherence_snr_min), ("C7", g_rg - p.coherence_rg_min),
                    ("C8", (b_max - b) / np.maximum(b_max, 1e-12))]
        ks = list(self.uavs)
        for i, a in enumerate(ks):
            for c in ks[i + 1:]:
                d = np.hypot(q[a][0] - q[c][0], q[a][1] - q[c][1])
                out.append(("C4", (d - p.d_min) / max(p.d_min, 1.0)))
        return [(name, np.broadcast_to(g, np.shape(v)[1:]).astype(float)) for name, g in out]
