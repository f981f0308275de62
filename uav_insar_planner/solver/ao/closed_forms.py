"""Closed-form pieces shared by the paper-faithful AO sub-problems (SI units, radians).

- Proposition 1's bound of a formation with its master on C2 (model.height_error_bound with
  b_perp,k from eq. 16),
- Proposition 2's C7a/C7b slopes alpha_a, alpha_b (None when the side is unconstrained),
- C6 as the master's range limit (exact: gamma_SNR is monotone in each slant range; the
  slaves' limit is model.slave_range_max).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.solver.problem import c7_sines


def b_perp_on_c2(p: Params, qk: np.ndarray) -> float:
    """b_perp,k of the slave at qk = (x_k, z_k) with the master on its C2 line (eq. 16)."""
    return float(model.perpendicular_baseline_fixed_look(qk[0], qk[1], p.x_t, p.theta0))


def formation_bound(p: Params, q0: np.ndarray, formation: np.ndarray,
                    slaves: Sequence[int]) -> float:
    """Proposition 1's bound K r_0 / sqrt(sum_k b_perp,k^2) for master q0 (on its C2 line) and
    the slaves' rows of `formation`; +inf when every b_perp,k is 0."""
    r0 = float(np.hypot(q0[0] - p.x_t, q0[1]))
    bsq = sum(b_perp_on_c2(p, formation[k]) ** 2 for k in slaves)
    return float(model.height_error_bound(p.wavelength, r0, p.theta0, bsq,
                                          model.worst_case_coherence(p), p.looks))


def c7_slopes(p: Params) -> tuple[float | None, float | None]:
    """(alpha_a, alpha_b) of Proposition 2: C7 <=> tan(theta_k) >= alpha_a on I_a and
    tan(theta_k) <= alpha_b on I_b, with h = the inverse of gamma_Rg(X) at gamma_Rg^min.

    A side whose arcsin argument leaves (0, 1) puts no restriction on 0 <= theta_k < pi/2
    (every look angle on that side meets C7) and gets None.
    """
    sines = c7_sines(p)
    if sines is None:  # C7 holds nowhere: the start grid finds no start, no AO runs
        return None, None
    arg_a, arg_b = sines
    alpha_a = math.tan(math.asin(arg_a)) if 0.0 < arg_a < 1.0 else None
    alpha_b = math.tan(math.asin(arg_b)) if 0.0 < arg_b < 1.0 else None
    return alpha_a, alpha_b


def master_range_max(p: Params, slave_ranges: list[float]) -> float:
    """Largest r_0 meeting C6 for every given slave range (the left side of C6 increases in
    r_0, so the limit is the root of (1 + r^3/g_m)(1 + r^2 r_k/g_m) = 1/gamma_SNR^min^2)."""
    gm = model.gamma_m(p)
    target = 1.0 / p.coherence_snr_min**2
    best = math.inf
    for rk in slave_ranges:
        # (r^3 + g)(g + r^2 rk) = target g^2  ->  rk r^5 + g r^3 + g rk r^2 + g^2 (1 - target)
        roots = np.roots([rk, 0.0, gm, gm * rk, 0.0, gm * gm * (1.0 - target)])
        real = [float(z.real) for z in roots if abs(z.imag) < 1e-9 * max(1.0, abs(z)) and
                z.real > 0.0]
        best = min(best, max(real) if real else 0.0)
    return best
