"""Problem (P) in polar coordinates about the target point, one look-angle ray at a time.

A UAV at look angle theta and slant range r sits at x = x_t - r sin(theta), z = r cos(theta)
(eq. 4 and the beam-centring look angle). C2 puts the master on the ray theta_0, so its only
freedom is r_0. With the master there, the perpendicular baseline of a slave is
b_perp = r |sin(theta - theta_0)| (eq. 16 in polar form), and along each slave ray every
constraint family allows an interval of ranges:

- C1: z_min / cos(theta) <= r <= z_max / cos(theta);
- C5: r >= S_min cos(theta) / Theta_3dB;
- C6: r <= gamma_m / r_0^2 (1 / (gamma_SNR^min^2 (1 + r_0^3 / gamma_m)) - 1)  (eqs. 7-9,
  model.slave_range_max);
- C8: r |sin(theta - theta_0)| <= lambda r_0 sin(theta_0) / h_amb,k^min  (eq. 12,
  model.baseline_max; slave k's own rung of h_amb_ratio's ladder);
- C9-C11: the cheapest schedule turns them into a disk about the ground station in the x-z
  plane (power.station_radius_sq), i.e. an interval [r_a, r_b] of the ray;
- C4 to the master removes an open interval (a hole) around the master's nearest point;
- C3 and C7 depend on theta only; C7 is the interval of Proposition 2 around theta_0.

Every function broadcasts over numpy arrays and takes the problem object (solver/problem.py:
its constants, the master's interval, C7's interval, the station disk's trace on a ray, and
`Problem.off`, the constraint families disabled, which is how the blocking set of an
infeasible scenario is found). The global back end (solver/global_opt/) searches this model;
report/figures.py draws the slaves' feasible regions from it.
"""
from __future__ import annotations

import math

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.solver.problem import Problem, disk_interval


def snr_limit(sc: Problem, r0):
    """C6's largest slave range at master range r0 (decreasing in r0); +inf when C6 is off."""
    if not sc.on("C6"):
        return np.full(np.shape(r0), math.inf)
    return model.slave_range_max(sc.p, r0)


def baseline_limit(sc: Problem, r0, k: int = 1):
    """C8's largest perpendicular baseline of slave k (model.baseline_max, its own rung);
    +inf when C8 is off."""
    if not sc.on("C8"):
        return np.full(np.shape(r0), math.inf)
    return model.baseline_max(sc.p, np.asarray(r0, dtype=float), k)


def ray_limits(sc: Problem, k: int, r0, theta):
    """(lo, up): slave k's ranges on ray theta allowed by C1, C5, C6, C8 and its station disk
    (the master hole excluded, see master_hole)."""
    theta = np.asarray(theta, dtype=float)
    p = sc.p
    cos = np.cos(theta)
    ra, rb = disk_interval(sc, k, theta)
    lo, up = np.maximum(ra, 0.0), rb
    if sc.on("C1"):
        lo, up = np.maximum(lo, p.z_min / cos), np.minimum(up, p.z_max / cos)
    if sc.on("C5"):
        lo = np.maximum(lo, p.swath_min * cos / p.beamwidth)
    up = np.minimum(up, snr_limit(sc, r0))
    with np.errstate(divide="ignore"):
        up = np.minimum(up, baseline_limit(sc, r0, k) / np.abs(np.sin(theta - sc.th0)))
    return lo, up


def master_hole(sc: Problem, r0, theta):
    """The open range interval (h1, h2) of ray theta closer than d_min to the master (C4);
    (inf, inf) when the ray misses that disk or C4 is off."""
    theta = np.asarray(theta, dtype=float)
    if not sc.on("C4"):
        inf = np.full(np.broadcast(r0, theta).shape, math.inf)
        return inf, inf
    dlt = theta - sc.th0
    disc = sc.p.d_min**2 - (r0 * np.sin(dlt)) ** 2
    root = np.sqrt(np.maximum(disc, 0.0))
    mid = r0 * np.cos(dlt)
    hit = disc > 0.0
    return np.where(hit, mid - root, math.inf), np.where(hit, mid + root, math.inf)


def coherence_rg(sc: Problem, theta):
    """gamma_Rg(theta) (eqs. 10-11)."""
    return model.coherence_baseline(model.chi(sc.th0, theta), sc.bp)


def snr_factor(sc: Problem, r0, r):
    """gamma_SNR (model.coherence_snr_at_ranges): decreasing in both r0 and r."""
    return model.coherence_snr_at_ranges(r0, r, sc.gm)


def weight(sc: Problem, b_perp, g_rg, g_snr):
    """w = b_perp^2 / sigma_Phi^2: the objective is lambda r0 sin(theta_0) / (2 pi sqrt(sum w))
    (eq. 15 with eqs. 12-14). `bound` uses sigma_Phi at the worst-case coherence A
    (Proposition 1); `exact` the coherence gamma = gamma_Rg gamma_SNR gamma_other; `multilook`
    the exact multilook phase std at gamma (multilook.phase_std: decreasing in gamma with
    d log sigma / d log((1 - gamma^2)/gamma^2) < 1, so every monotonicity the bounds use holds as
    for `exact`, whose slope is 1/2; see solver/global_opt/slave_ranges.py)."""
    b2 = np.asarray(b_perp, dtype=float) ** 2
    if sc.objective == "bound":
        return b2 / sc.sigma_phi_bound**2
    g = np.asarray(g_rg) * np.asarray(g_snr) * sc.p.coherence_other
    if sc.objective == "multilook":
        from uav_insar_planner.multilook import phase_std

        return b2 / phase_std(g, sc.p.looks) ** 2
    # sigma_Phi^2 = (1 - g^2) / (2 n_L g^2)
    return b2 * 2.0 * sc.p.looks * g * g / (1.0 - g * g)


def objective_from_weights(sc: Problem, r0, wsum):
    """sigma_h (or its bound) = lambda r0 sin(theta_0) / (2 pi sqrt(sum_k w_k))."""
    with np.errstate(divide="ignore"):
        return sc.p.wavelength * np.asarray(r0) * sc.sin0 / (2.0 * math.pi * np.sqrt(wsum))


def position(sc: Problem, r, theta) -> tuple[float, float]:
    """(x, z) of range r on look-angle ray theta."""
    return sc.p.x_t - r * math.sin(theta), r * math.cos(theta)
