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

Every function broadcasts over numpy arrays. `Scenario.off` disables constraint families,
which is how the blocking set of an infeasible scenario is found. The global back end
(solver/global_opt/) searches this model; report/figures.py draws the slaves' feasible
regions from it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.schemes import slave_uavs
from uav_insar_planner.solver.power import station_radius_sq
from uav_insar_planner.swarm import uavs

HALF_PI = 0.5 * math.pi
# Look angles are kept strictly inside (-pi/2, pi/2) so that z = r cos(theta) > 0.
THETA_EDGE = HALF_PI - 1e-9


@dataclass(frozen=True)
class Scenario:
    """Everything the ray model needs, precomputed once per (params, scheme, objective)."""

    p: Params
    scheme: str
    objective: str
    off: frozenset[str]
    slaves: tuple[int, ...]
    gm: float
    th0: float
    sin0: float
    bp: float
    disk_r2: tuple[float, ...]            # per UAV, +inf when unconstrained
    station_dist: float                    # |g - p_t| in the x-z plane
    station_angle: float                   # look angle of the station seen from p_t
    r0_lo: float                           # master range interval; lo > hi when empty
    r0_hi: float
    th_lo: float                           # slave look-angle domain (C3 and C7)
    th_hi: float
    sigma_phi_bound: float                 # sigma_Phi at the worst-case coherence A

    def on(self, family: str) -> bool:
        return family not in self.off


def make_scenario(p: Params, scheme: str, objective: str,
                  off: frozenset[str] = frozenset()) -> Scenario:
    th0 = p.theta0
    bp = p.radar_bandwidth_hz / p.center_frequency_hz
    ox, oz = p.ground_station[0] - p.x_t, p.ground_station[2]
    disk = tuple(station_radius_sq(p, k, scheme, off) for k in uavs(p.num_uavs))
    sc = Scenario(p=p, scheme=scheme, objective=objective, off=off,
                  slaves=slave_uavs(scheme, p.num_uavs),
                  gm=model.gamma_m(p), th0=th0, sin0=math.sin(th0), bp=bp, disk_r2=disk,
                  station_dist=math.hypot(ox, oz), station_angle=math.atan2(-ox, oz),
                  r0_lo=0.0, r0_hi=0.0, th_lo=0.0, th_hi=0.0,
                  sigma_phi_bound=float(model.phase_error_crb(model.worst_case_coherence(p),
                                                              p.looks)))
    th_lo, th_hi = -THETA_EDGE, THETA_EDGE
    if sc.on("C3"):
        th_lo, th_hi = max(th_lo, p.theta_min), min(th_hi, p.theta_max)
    if sc.on("C7"):
        a, b = c7_interval(sc)
        th_lo, th_hi = max(th_lo, a), min(th_hi, b)
    r0_lo, r0_hi = master_interval(sc)
    return replace(sc, r0_lo=r0_lo, r0_hi=r0_hi, th_lo=th_lo, th_hi=th_hi)


def c7_interval(sc: Scenario) -> tuple[float, float]:
    """Look angles with gamma_Rg >= gamma_Rg^min (Proposition 2): gamma_Rg decreases in X and
    X grows with |theta - theta_0| on both sides, so the set is an interval around theta_0."""
    h = model.coherence_baseline_inverse(sc.p.coherence_rg_min, sc.bp)
    if h < 1.0:  # even X = 1 (theta = theta_0) misses the threshold
        return 1.0, -1.0
    lo = math.asin(min(1.0, (2.0 - h) / h * sc.sin0))
    hi_arg = h / (2.0 - h) * sc.sin0 if h < 2.0 else math.inf
    hi = math.asin(hi_arg) if hi_arg < 1.0 else THETA_EDGE
    return lo, hi


def disk_interval(sc: Scenario, k: int, theta):
    """[r_a, r_b]: the ray's ranges inside UAV k's station disk (C9-C11); r_a > r_b if none.

    With psi = |theta - station angle|, r_b = D cos(psi) + sqrt(R^2 - D^2 sin^2 psi) is
    non-increasing in psi and r_a = D cos(psi) - sqrt(...) is non-decreasing in psi wherever
    the ray meets the disk beyond the target (which is what interval bounds rely on)."""
    r2 = sc.disk_r2[k]
    theta = np.asarray(theta, dtype=float)
    if r2 == math.inf:
        return np.full(theta.shape, -math.inf), np.full(theta.shape, math.inf)
    return _disk_at_psi(sc, r2, angle_between(theta, sc.station_angle))


def angle_between(a, b):
    """|a - b| wrapped into [0, pi]."""
    return np.abs(np.remainder(np.asarray(a) - b + math.pi, 2.0 * math.pi) - math.pi)


def _disk_at_psi(sc: Scenario, r2: float, psi):
    d = sc.station_dist
    disc = r2 - (d * np.sin(psi)) ** 2
    root = np.sqrt(np.maximum(disc, 0.0))
    tc = d * np.cos(psi)
    ok = (disc >= 0.0) & (tc + root >= 0.0)
    return np.where(ok, tc - root, math.inf), np.where(ok, tc + root, -math.inf)


def master_interval(sc: Scenario) -> tuple[float, float]:
    """Master ranges r_0 allowed by C1, C5, C9-C11 (its disk) and C6's need for a positive
    SNR margin; (lo, hi) with lo > hi when empty. Fixed-master: the given point, if it meets
    them (C2 is checked by the caller)."""
    p, c0 = sc.p, math.cos(sc.th0)
    lo, hi = 0.0, math.inf
    if sc.on("C1"):
        lo, hi = max(lo, p.z_min / c0), min(hi, p.z_max / c0)
    if sc.on("C5"):
        lo = max(lo, p.swath_min * c0 / p.beamwidth)
    ra, rb = disk_interval(sc, 0, sc.th0)
    lo, hi = max(lo, float(ra)), min(hi, float(rb))
    if sc.on("C6"):
        # C6 needs (1 + r0^3/gm) < 1/gamma^2 for any slave range to be allowed.
        hi = min(hi, (sc.gm * (1.0 / p.coherence_snr_min**2 - 1.0)) ** (1.0 / 3.0))
    if sc.scheme == "fixed-master":
        r0 = math.hypot(p.master_fixed[0] - p.x_t, p.master_fixed[1])
        return (r0, r0) if lo <= r0 <= hi else (1.0, 0.0)
    return lo, hi


def snr_limit(sc: Scenario, r0):
    """C6's largest slave range at master range r0 (decreasing in r0); +inf when C6 is off."""
    if not sc.on("C6"):
        return np.full(np.shape(r0), math.inf)
    return model.slave_range_max(sc.p, r0)


def baseline_limit(sc: Scenario, r0, k: int = 1):
    """C8's largest perpendicular baseline of slave k (model.baseline_max, its own rung);
    +inf when C8 is off."""
    if not sc.on("C8"):
        return np.full(np.shape(r0), math.inf)
    return model.baseline_max(sc.p, np.asarray(r0, dtype=float), k)


def ray_limits(sc: Scenario, k: int, r0, theta):
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


def master_hole(sc: Scenario, r0, theta):
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


def coherence_rg(sc: Scenario, theta):
    """gamma_Rg(theta) (eqs. 10-11)."""
    return model.coherence_baseline(model.chi(sc.th0, theta), sc.bp)


def snr_factor(sc: Scenario, r0, r):
    """gamma_SNR (model.coherence_snr_at_ranges): decreasing in both r0 and r."""
    return model.coherence_snr_at_ranges(r0, r, sc.gm)


def weight(sc: Scenario, b_perp, g_rg, g_snr):
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


def objective_from_weights(sc: Scenario, r0, wsum):
    """sigma_h (or its bound) = lambda r0 sin(theta_0) / (2 pi sqrt(sum_k w_k))."""
    with np.errstate(divide="ignore"):
        return sc.p.wavelength * np.asarray(r0) * sc.sin0 / (2.0 * math.pi * np.sqrt(wsum))


def position(sc: Scenario, r, theta) -> tuple[float, float]:
    """(x, z) of range r on look-angle ray theta."""
    return sc.p.x_t - r * math.sin(theta), r * math.cos(theta)
