"""Problem (P), stated once for every back end, as pymoo's `Problem` serves every algorithm.

The independent checker (evaluate.py) keeps its own statement on purpose; the back ends share
this one. `Problem` holds one scenario, scheme and objective: which UAVs fly, the constraint
families switched off (`off`: how the blocking set of an infeasible scenario is found), the
constants every constraint needs, computed once (gamma_m, theta_0, B_Rg/f_0, each UAV's C9-C11
station disk), and the bounds of the decision variables. (P) is written over two sets of
variables, both with C2 built in (the master on its look-angle line):

- ray coordinates, v = (r0, theta_1..theta_K, r_1..r_K): a UAV at look angle theta and slant
  range r sits at x = x_t - r sin(theta), z = r cos(theta). Bounds: r0 in [r0_lo, r0_hi]
  (`master_interval`: C1, C5, the master's station disk, C6's need for a positive SNR margin;
  the given point for the fixed master), theta in [th_lo, th_hi] (C3 and C7's interval of
  Proposition 2, `c7_interval`), r >= 0. Constraints: `ray_slacks`. The global back end
  (solver/rays.py, solver/global_opt/) and the start grid use them;
- Cartesian coordinates, v = (z_0, x_1, z_1, ..., x_K, z_K) (no z_0 for the fixed master):
  bounds `cartesian_bounds`, constraints `cartesian_slacks`; the evolution back end uses them.

Each constraint function returns (tag, slack) pairs, the tag the family C1..C11 of the paper
and the slack >= 0 where the family holds. C9-C11 enter as the station disk of the cheapest
schedule (power.station_radius_sq, exact: no other schedule does better); the AO's CVXPY
sub-problems keep P_com,k as a variable and take their scheme, slaves and C7 from here.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.schemes import active_uavs, slave_uavs
from uav_insar_planner.solver.power import station_radius_sq
from uav_insar_planner.swarm import MASTER, uavs

HALF_PI = 0.5 * math.pi
# Look angles are kept strictly inside (-pi/2, pi/2) so that z = r cos(theta) > 0.
THETA_EDGE = HALF_PI - 1e-9


@dataclass(frozen=True)
class Problem:
    """(P) for one (params, scheme, objective), everything precomputed once (module docstring)."""

    p: Params
    scheme: str
    objective: str
    off: frozenset[str]
    uavs: tuple[int, ...]                  # the UAVs the scheme flies, master first
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

    @property
    def fixed_master(self) -> bool:
        """Benchmark 2: the master sits at q0_fixed, not on a variable of (P)."""
        return self.scheme == "fixed-master"


def make_problem(p: Params, scheme: str, objective: str,
                 off: frozenset[str] = frozenset()) -> Problem:
    th0 = p.theta0
    bp = p.fractional_bandwidth
    ox, oz = p.ground_station[0] - p.x_t, p.ground_station[2]
    disk = tuple(station_radius_sq(p, k, scheme, off) for k in uavs(p.num_uavs))
    pr = Problem(p=p, scheme=scheme, objective=objective, off=off,
                 uavs=active_uavs(scheme, p.num_uavs), slaves=slave_uavs(scheme, p.num_uavs),
                 gm=model.gamma_m(p), th0=th0, sin0=math.sin(th0), bp=bp, disk_r2=disk,
                 station_dist=math.hypot(ox, oz), station_angle=math.atan2(-ox, oz),
                 r0_lo=0.0, r0_hi=0.0, th_lo=0.0, th_hi=0.0,
                 sigma_phi_bound=float(model.phase_error_crb(model.worst_case_coherence(p),
                                                             p.looks)))
    th_lo, th_hi = -THETA_EDGE, THETA_EDGE
    if pr.on("C3"):
        th_lo, th_hi = max(th_lo, p.theta_min), min(th_hi, p.theta_max)
    if pr.on("C7"):
        a, b = c7_interval(pr)
        th_lo, th_hi = max(th_lo, a), min(th_hi, b)
    r0_lo, r0_hi = master_interval(pr)
    return replace(pr, r0_lo=r0_lo, r0_hi=r0_hi, th_lo=th_lo, th_hi=th_hi)


def c7_sines(p: Params) -> tuple[float, float] | None:
    """C7 (gamma_Rg >= gamma_Rg^min, Proposition 2) as sin(theta) bounds: gamma_Rg decreases in
    X, and X grows with |theta - theta_0| on both sides, so C7 is
    (2 - h)/h sin(theta_0) <= sin(theta) <= h/(2 - h) sin(theta_0) with h the X at which
    gamma_Rg = gamma_Rg^min (the upper one +inf for h >= 2); None when even X = 1
    (theta = theta_0) misses the threshold."""
    h = model.coherence_baseline_inverse(p.coherence_rg_min, p.fractional_bandwidth)
    if h < 1.0:
        return None
    s0 = math.sin(p.theta0)
    return (2.0 - h) / h * s0, (h / (2.0 - h) * s0 if h < 2.0 else math.inf)


def c7_interval(pr: Problem) -> tuple[float, float]:
    """Look angles with gamma_Rg >= gamma_Rg^min (`c7_sines`); (1, -1) when none."""
    sines = c7_sines(pr.p)
    if sines is None:
        return 1.0, -1.0
    lo = math.asin(min(1.0, sines[0]))
    hi = math.asin(sines[1]) if sines[1] < 1.0 else THETA_EDGE
    return lo, hi


def angle_between(a, b):
    """|a - b| wrapped into [0, pi]."""
    return np.abs(np.remainder(np.asarray(a) - b + math.pi, 2.0 * math.pi) - math.pi)


def disk_at_psi(pr: Problem, r2: float, psi):
    """[r_a, r_b]: the ranges of a ray at angle psi from the station's direction inside a disk
    of squared radius r2 about the station (C9-C11); r_a = inf, r_b = -inf where none.

    r_b = D cos(psi) + sqrt(R^2 - D^2 sin^2 psi) is non-increasing in psi and
    r_a = D cos(psi) - sqrt(...) is non-decreasing in psi wherever the ray meets the disk
    beyond the target (which is what interval bounds rely on)."""
    d = pr.station_dist
    disc = r2 - (d * np.sin(psi)) ** 2
    root = np.sqrt(np.maximum(disc, 0.0))
    tc = d * np.cos(psi)
    ok = (disc >= 0.0) & (tc + root >= 0.0)
    return np.where(ok, tc - root, math.inf), np.where(ok, tc + root, -math.inf)


def disk_interval(pr: Problem, k: int, theta):
    """[r_a, r_b]: ray theta's ranges inside UAV k's station disk (C9-C11); r_a > r_b if none
    (`disk_at_psi`), (-inf, inf) when nothing limits them."""
    r2 = pr.disk_r2[k]
    theta = np.asarray(theta, dtype=float)
    if r2 == math.inf:
        return np.full(theta.shape, -math.inf), np.full(theta.shape, math.inf)
    return disk_at_psi(pr, r2, angle_between(theta, pr.station_angle))


def master_interval(pr: Problem) -> tuple[float, float]:
    """Master ranges r_0 allowed by C1, C5, C9-C11 (its disk) and C6's need for a positive
    SNR margin; (lo, hi) with lo > hi when empty. Fixed-master: the given point, if it meets
    them (C2 is checked by the caller)."""
    p, c0 = pr.p, math.cos(pr.th0)
    lo, hi = 0.0, math.inf
    if pr.on("C1"):
        lo, hi = max(lo, p.z_min / c0), min(hi, p.z_max / c0)
    if pr.on("C5"):
        lo = max(lo, p.swath_min * c0 / p.beamwidth)
    ra, rb = disk_interval(pr, 0, pr.th0)
    lo, hi = max(lo, float(ra)), min(hi, float(rb))
    if pr.on("C6"):
        # C6 needs (1 + r0^3/gm) < 1/gamma^2 for any slave range to be allowed.
        hi = min(hi, (pr.gm * (1.0 / p.coherence_snr_min**2 - 1.0)) ** (1.0 / 3.0))
    if pr.fixed_master:
        r0 = math.hypot(p.master_fixed[0] - p.x_t, p.master_fixed[1])
        return (r0, r0) if lo <= r0 <= hi else (1.0, 0.0)
    return lo, hi


def ray_slacks(pr: Problem, r0, th, r) -> list[tuple[str, np.ndarray]]:
    """(tag, slack) in ray coordinates for m points: r0 (m,), th and r (m, K), slacks (m, n)
    in metres. C1: z_k = r_k cos(theta_k) in [z_min, z_max]; C5: r_k >= S_min cos(theta_k) /
    Theta; C6: r_k <= model.slave_range_max(r0); C8: r_k |sin(theta_k - theta_0)| <= b_max,k(r0)
    (slave k's rung); C10 (with C9, C11): |q_k - g|^2 <= disk_r2[k], scaled by the disk's
    radius; C4: |q_i - q_j|^2 >= d_min^2 for every pair, the master included, scaled by
    d_min. C2, C3, C7 and the master's own limits are the variables' bounds."""
    p = pr.p
    x, z = -r * np.sin(th), r * np.cos(th)                    # relative to the target
    out: list[tuple[str, np.ndarray]] = []
    if pr.on("C1"):
        out += [("C1", z - p.z_min), ("C1", p.z_max - z)]
    if pr.on("C5"):
        out.append(("C5", r - p.swath_min * np.cos(th) / p.beamwidth))
    if pr.on("C6"):
        out.append(("C6", model.slave_range_max(p, r0)[:, None] - r))
    if pr.on("C8"):
        b_max = np.stack([model.baseline_max(p, r0, k) for k in pr.slaves], axis=1)
        out.append(("C8", b_max - r * np.abs(np.sin(th - pr.th0))))
    gx, gz = p.ground_station[0] - p.x_t, p.ground_station[2]
    for j, k in enumerate(pr.slaves):
        if math.isfinite(pr.disk_r2[k]):
            d2 = (x[:, j] - gx) ** 2 + (z[:, j] - gz) ** 2
            out.append(("C10", ((pr.disk_r2[k] - d2)
                                / max(math.sqrt(abs(pr.disk_r2[k])), 1.0))[:, None]))
    if pr.on("C4"):
        xs = np.concatenate([(-r0 * pr.sin0)[:, None], x], axis=1)  # (m, 1 + K), master first
        zs = np.concatenate([(r0 * math.cos(pr.th0))[:, None], z], axis=1)
        i, j = pairs(xs.shape[1])
        gap2 = ((xs[:, i] - xs[:, j]) ** 2 + (zs[:, i] - zs[:, j]) ** 2) - p.d_min**2
        out.append(("C4", gap2 / max(p.d_min, 1e-3)))
    return out


@functools.cache
def pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """np.triu_indices(n, 1), built once per n (it costs more than the C4 slacks it indexes)."""
    i, j = np.triu_indices(n, 1)
    i.flags.writeable = j.flags.writeable = False
    return i, j


def cartesian_bounds(pr: Problem) -> list[tuple[float, float]]:
    """Bounds of the Cartesian variables (z_0 unless the master is fixed, then (x_k, z_k) per
    slave), valid for every feasible point, so the box loses nothing: z_0 from C1, C5
    (r_0 >= S_min cos(theta_0)/Theta_3dB) and C6 with a slave on the target (r_0^3 <= gamma_m
    (1/gamma_SNR^min^2 - 1)); a slave within R = model.slave_range_max at the least r_0, at a
    look angle in [theta_min, theta_max] (C3), so z_k <= R cos(theta_min) and
    x_t - R sin(theta_max) <= x_k <= x_t - z_min tan(theta_min)."""
    p = pr.p
    c0 = math.cos(p.theta0)
    r0_lo = max(p.z_min / c0, p.swath_min * c0 / p.beamwidth)
    r0_hi = (pr.gm * (1.0 / p.coherence_snr_min**2 - 1.0)) ** (1.0 / 3.0)
    out = [] if pr.fixed_master else [(r0_lo * c0, min(p.z_max, r0_hi * c0))]
    r0_least = math.hypot(*(np.subtract(p.master_fixed, (p.x_t, 0.0)))) \
        if pr.fixed_master else r0_lo
    reach = float(model.slave_range_max(p, r0_least))
    z_hi = min(p.z_max, reach * math.cos(p.theta_min))
    x_lo, x_hi = p.x_t - reach * math.sin(p.theta_max), p.x_t - p.z_min * math.tan(p.theta_min)
    for _ in pr.slaves:
        out += [(x_lo, x_hi), (p.z_min, z_hi)]
    return out


Positions = dict[int, tuple[np.ndarray, np.ndarray]]  # UAV k -> (x_k, z_k), broadcast alike


def pair_terms(pr: Problem, q: Positions) -> tuple[np.ndarray, dict[int, tuple]]:
    """r_0 and, per slave, (b_perp,k, gamma_SNR,k, gamma_Rg,k, theta_k) (eqs. 3, 7-11)."""
    p = pr.p
    x0, z0 = q[MASTER]
    r0 = model.slant_range(x0, z0, p.x_t)
    out = {}
    for k in pr.slaves:
        xk, zk = q[k]
        theta = model.look_angle(xk, zk, p.x_t)
        rk = model.slant_range(xk, zk, p.x_t)
        out[k] = (model.perpendicular_baseline(x0, z0, xk, zk, p.theta0),
                  model.coherence_snr_at_ranges(r0, rk, pr.gm),
                  model.coherence_baseline(model.chi(p.theta0, theta), pr.bp), theta)
    return r0, out


def cartesian_slacks(pr: Problem, q: Positions) -> list[tuple[str, np.ndarray]]:
    """(tag, slack) of C1, C3-C11 at the positions q, each scaled to order one (lengths by a
    length of their own family, coherences as they are), all from model.py: C1 z_min <= z_k
    <= z_max; C3 theta_min <= theta_k <= theta_max; C4 ||q_i - q_j|| >= d_min; C5 Theta_3dB
    r_k / cos(theta_k) >= S_min; C6 gamma_SNR,k >= gamma_SNR^min (eq. 7); C7 gamma_Rg,k >=
    gamma_Rg^min (eq. 10); C8 b_perp,k <= b_max,k(r_0) (model.baseline_max, slave k's rung);
    C10 (with C9, C11) rho_k^2 <= disk_r2[k], rho_k the x-z distance to the station."""
    p = pr.p
    r0, pairs = pair_terms(pr, q)
    out: list[tuple[str, np.ndarray]] = []
    zscale = max(p.z_max - p.z_min, 1.0)
    for k in pr.uavs:
        x, z = q[k]
        out += [("C1", (z - p.z_min) / zscale), ("C1", (p.z_max - z) / zscale)]
        theta = p.theta0 if k == MASTER else pairs[k][3]
        r = model.slant_range(x, z, p.x_t)
        out.append(("C5", (model.swath_width(r, theta, p.beamwidth) - p.swath_min)
                    / max(p.swath_min, 1.0)))
        rad = pr.disk_r2[k]
        if math.isfinite(rad):
            rho_sq = (x - p.ground_station[0]) ** 2 + (z - p.ground_station[2]) ** 2
            out.append(("C10", (rad - rho_sq) / max(abs(rad), 1.0)))
    for k, (b, g_snr, g_rg, theta) in pairs.items():
        b_max = model.baseline_max(p, r0, k)  # slave k's own C8 rung (h_amb_ratio)
        out += [("C3", theta - p.theta_min), ("C3", p.theta_max - theta),
                ("C6", g_snr - p.coherence_snr_min), ("C7", g_rg - p.coherence_rg_min),
                ("C8", (b_max - b) / np.maximum(b_max, 1e-12))]
    ks = list(pr.uavs)
    for i, a in enumerate(ks):
        for c in ks[i + 1:]:
            d = np.hypot(q[a][0] - q[c][0], q[a][1] - q[c][1])
            out.append(("C4", (d - p.d_min) / max(p.d_min, 1.0)))
    return out
