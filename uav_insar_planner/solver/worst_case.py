"""A plan under navigation error: its certified worst-case sigma_h and constraint slacks.

Every UAV k may fly anywhere in the disk D_k of radius e = nav_error_m about its planned point
q_k in the across-track plane, with the plan's own power schedule. Target p_t = (x_t, 0),
n = (cos theta_0, sin theta_0) the normal to the master's line of sight, so that b_perp,k =
|n . (q_k - q_0)| (eq. 3) and h_amb,k = lambda r_0 sin(theta_0) / b_perp,k (eq. 12).

Worst-case sigma_h (`worst_sigma`). sigma_h^-2 = sum_k w_k with
w_k = (2 pi b_perp,k / (lambda r_0 sin(theta_0) sigma_Phi,k))^2 (eqs. 13-15): for a fixed master
position the slaves separate, and the worst case is max over q_0' in D_0 of
(sum_k min over q_k' in D_k of w_k)^(-1/2). A branch and bound over squares S covering D_0
bounds each w_k from below over S x D_k: D_k is cut across n into `STRIPS` strips (thin
where D_k is, at its ends along n; `_strips`) and on each strip every factor is at its least
favourable value: b_perp >= the distance of the interval n . q_k + [t_1, t_2] - n . S from 0,
r_0 <= the farthest corner of S (and <= r_0 + e), r_k <= the strip's farthest point (and
<= r_k + e; gamma_SNR, eq. 7, falls in both ranges), gamma_Rg >= its value at the ends of the
strip's look angles (within theta_k +- asin(e / r_k); gamma_Rg is unimodal with its peak at
theta_0, eq. 10), and sigma_Phi (eq. 14) falls in gamma; the least over the strips bounds
min over D_k of w_k. One bound for the whole disk would pair b_perp's least (the slave e along
n) with r_k's largest and gamma_Rg's least, which no one point has; the strips keep them
apart, and the thin strips at the disk's ends along n, where b_perp is least, vary little in
r_k and the look angle. That gives an upper bound U(S) on sigma_h over S; the square with the
largest U is split in four until U is within `WORST_TOL` of the largest sigma_h found at
actual positions (square centres in D_0, each slave at the worst of `RIM_POINTS` points of its
rim). `upper` is then a certified upper bound of the
worst case, `achieved` a value some positions in the disks attain.

Constraints (`robust_slacks`): each family's least slack over the disks, exact or conservative
(never above the true least slack):

- C1: z_k - e >= z_min, z_k + e <= z_max (exact);
- C3: theta_k -+ asin(e / r_k) within [theta_min, theta_max] (exact: the tangents from p_t);
- C4: ||q_i - q_j|| - 2e >= d_min (exact);
- C5: master Theta (r_0 - e) / cos(theta_0) >= S_min (exact: the master's swath uses theta_0);
  slave Theta r^2 / z >= Theta (r_k - e)^2 / (z_k + e) >= S_min (conservative);
- C6: gamma_SNR(r_0 + e, r_k + e) >= gamma_SNR^min (exact: it falls in both ranges);
- C7: gamma_Rg at theta_k -+ asin(e / r_k) >= gamma_Rg^min (exact, unimodal);
- C8: h_amb over the disks is least with the slave e outwards along n (b_perp + e = B) and
  the master on its rim at angle phi from its line of sight, b_perp B + e sin phi, r_0' =
  |r_0 + e e^(i phi)| >= r_0 + e cos phi; so h_amb >= lambda sin(theta_0) min_phi (r_0 + e cos
  phi) / (B + e sin phi), a ratio of linear forms whose least value t solves
  (r_0 - t B)^2 = e^2 (1 + t^2) (`h_amb_worst`; conservative by at most e^2 / (2 r_0) in r_0);
- C10: the rate of the plan's P_com,k[n] at distance sqrt((rho_k + e)^2 + (y[n] - g_y)^2)
  (exact: the farthest point of D_k from the station); C9 and C11 bind the schedule alone.
"""
from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.plan import ConstraintStatus
from uav_insar_planner.schemes import active_uavs, planned_rate_bps, slave_uavs
from uav_insar_planner.solver.power import station_radius_sq
from uav_insar_planner.swarm import MASTER

# The bound stops when it is within this fraction of a sigma_h attained in the disks.
WORST_TOL = 1e-3
# Points on each slave's rim tried for the attained value (a lower estimate of the worst case).
RIM_POINTS = 72
MAX_SQUARES = 20000
# Squares split together, and the side (in e) below which the master's square is not split:
# what is left of the gap there is the slaves' bounds' (r_k + e, the look-angle ends).
BATCH = 32
MIN_SIDE = 1.0 / 64.0
# Strips across n each slave's disk is cut into (`_strips`).
STRIPS = 48


@dataclass(frozen=True)
class WorstCase:
    """upper: certified upper bound of sigma_h over the disks; achieved: sigma_h at positions
    within them (upper >= worst >= achieved); squares: how many the search bounded."""

    upper: float
    achieved: float
    squares: int


def gamma_rg(p: Params, theta):
    bp = p.fractional_bandwidth
    return model.coherence_baseline(model.chi(p.theta0, theta), bp)


def look_spread(e: float, r):
    """asin(e / r): the most a look angle moves over a disk of radius e at range r (pi/2 when
    the disk reaches the target)."""
    return np.arcsin(np.minimum(e / np.maximum(np.asarray(r, dtype=float), 1e-300), 1.0))


def pair_weight(p: Params, b, r0, gamma):
    """w = (2 pi b / (lambda r_0 sin(theta_0) sigma_Phi(gamma)))^2; 0 where gamma <= 0."""
    g = np.clip(gamma, 1e-300, 1.0)
    sig = model.phase_error_crb(g, p.looks)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = (2.0 * math.pi * b / (p.wavelength * r0 * math.sin(p.theta0) * sig)) ** 2
    return np.where((np.asarray(gamma) > 0) & np.isfinite(w), w, 0.0)


def _sigma(wsum):
    with np.errstate(divide="ignore"):
        return np.where(wsum > 0, 1.0 / np.sqrt(np.maximum(wsum, 1e-300)), np.inf)


def _strips(p: Params, qk: np.ndarray, e: float) -> tuple[np.ndarray, ...]:
    """Slave disk D_k cut across n into STRIPS strips t = n . (q' - q_k) in [-e cos a_1,
    -e cos a_2] (a uniform in [0, pi]: thin where D_k is thin, near its points nearest and
    farthest along n). A strip's part of D_k lies in the rectangle of those t and of offsets
    v along the line of sight |v| <= h, h the largest half-chord sqrt(e^2 - t^2) over the strip:
    its corners bound the range (r_k at most the farthest corner, distance being convex, and at
    most r_k + e) and the look angles (the polar angle from p_t over a convex set without p_t
    spans its corners' angles; within theta_k -+ asin(e / r_k) too), and gamma_Rg is least at
    one end of that interval (unimodal, peak at theta_0). Returns (t1, t2, r_k max, gamma_Rg
    min) per strip."""
    n = np.array([math.cos(p.theta0), math.sin(p.theta0)])
    u = np.array([-n[1], n[0]])
    a = np.linspace(0.0, math.pi, STRIPS + 1)
    t1, t2 = -e * np.cos(a[:-1]), -e * np.cos(a[1:])
    h = e * np.where((a[:-1] < math.pi / 2) & (a[1:] > math.pi / 2), 1.0,
                     np.maximum(np.sin(a[:-1]), np.sin(a[1:])))
    xs, zs = [], []
    for t in (t1, t2):
        for v in (-h, h):
            xs.append(qk[0] + t * n[0] + v * u[0])
            zs.append(qk[1] + t * n[1] + v * u[1])
    x, z = np.stack(xs), np.stack(zs)
    rk = float(model.slant_range(qk[0], qk[1], p.x_t))
    r_hi = np.minimum(model.slant_range(x, z, p.x_t).max(axis=0), rk + e)
    th, spread = float(model.look_angle(qk[0], qk[1], p.x_t)), float(look_spread(e, rk))
    ang = model.look_angle(x, z, p.x_t)
    lo, hi = np.maximum(ang.min(axis=0), th - spread), np.minimum(ang.max(axis=0), th + spread)
    return t1, t2, r_hi, np.minimum(gamma_rg(p, lo), gamma_rg(p, hi))


def _cell_upper(p: Params, q: np.ndarray, strips: dict, e: float, sq: np.ndarray):
    """U(S) for squares sq (m, 4) = (x_a, x_b, z_a, z_b) of master positions (module
    docstring): each slave's w_k bounded below on each strip of its disk (`_strips`), the
    least over its strips taken."""
    n = np.array([math.cos(p.theta0), math.sin(p.theta0)])
    corners = [(sq[:, i], sq[:, j]) for i in (0, 1) for j in (2, 3)]
    proj = np.stack([n[0] * x + n[1] * z for x, z in corners])
    r0c = np.stack([np.hypot(x - p.x_t, z) for x, z in corners])
    r0_hi = np.minimum(r0c.max(axis=0), float(np.hypot(q[0, 0] - p.x_t, q[0, 1])) + e)[:, None]
    gm = model.gamma_m(p)
    wsum = np.zeros(len(sq))
    for k, (t1, t2, r_hi, g_rg) in strips.items():
        lo = n @ q[k] + t1[None, :] - proj.max(axis=0)[:, None]
        hi = n @ q[k] + t2[None, :] - proj.min(axis=0)[:, None]
        b_lo = np.where(lo > 0, lo, np.where(hi < 0, -hi, 0.0))
        g = g_rg[None, :] * model.coherence_snr_at_ranges(r0_hi, r_hi[None, :], gm)
        wsum = wsum + pair_weight(p, b_lo, r0_hi, g * p.coherence_other).min(axis=1)
    return _sigma(wsum)


def _attained(p: Params, q: np.ndarray, slaves, e: float, masters: np.ndarray):
    """sigma_h with the master at each row of `masters` and each slave at the worst of
    RIM_POINTS rim points: positions in the disks, so a value the worst case reaches."""
    phi = np.linspace(0.0, 2.0 * math.pi, RIM_POINTS, endpoint=False)
    wsum = np.zeros(len(masters))
    x0, z0 = masters[:, :1], masters[:, 1:]
    for k in slaves:
        xk, zk = q[k, 0] + e * np.cos(phi), q[k, 1] + e * np.sin(phi)
        pm = pair_sigma(p, x0, z0, xk[None], zk[None])
        wsum = wsum + (1.0 / pm**2).min(axis=1)
    return _sigma(wsum)


def pair_sigma(p: Params, x0, z0, xk, zk):
    """sigma_h,k of the pair at these positions, as the checker computes it (evaluate.py)."""
    gm = model.gamma_m(p)
    r0 = model.slant_range(x0, z0, p.x_t)
    g = model.coherence_total(gamma_rg(p, model.look_angle(xk, zk, p.x_t)),
                              model.coherence_snr(model.snr_monostatic(r0, gm),
                                                  model.snr_bistatic(r0, model.slant_range(
                                                      xk, zk, p.x_t), gm)),
                              p.coherence_other)
    b = model.perpendicular_baseline(x0, z0, xk, zk, p.theta0)
    return model.height_error(model.height_of_ambiguity(p.wavelength, r0, p.theta0, b),
                              model.phase_error_crb(g, p.looks))


def worst_sigma(p: Params, formation: np.ndarray, scheme: str,
                tol: float = WORST_TOL) -> WorstCase:
    """The certified worst case of the fused sigma_h over the disks (module docstring)."""
    q = np.asarray(formation, dtype=float)
    slaves = slave_uavs(scheme, p.num_uavs)
    e = p.nav_error_m
    if e == 0.0:
        s = float(_attained(p, q, slaves, 0.0, q[:1])[0])
        return WorstCase(s, s, 1)
    x0, z0 = q[MASTER]
    strips = {k: _strips(p, q[k], e) for k in slaves}

    def bound(squares: np.ndarray):
        centre = np.stack([(squares[:, 0] + squares[:, 1]) / 2,
                           (squares[:, 2] + squares[:, 3]) / 2], axis=1)
        off = centre - q[MASTER]
        dist = np.hypot(off[:, 0], off[:, 1])
        inside = np.where((dist > e)[:, None], off * (e / np.maximum(dist, 1e-300))[:, None], off)
        return _cell_upper(p, q, strips, e, squares), _attained(p, q, slaves, e,
                                                                q[MASTER] + inside)

    first = np.array([[x0 - e, x0 + e, z0 - e, z0 + e]])
    up, got = bound(first)
    best = float(got[0])
    heap = [(-float(up[0]), 0, tuple(first[0]))]
    count = 1
    while count < MAX_SQUARES:
        top = -heap[0][0]
        if top - best <= tol * top or heap[0][2][1] - heap[0][2][0] < e * MIN_SIDE:
            break  # within tol, or the slaves' own bounds (not the master's) hold the rest
        batch = [heapq.heappop(heap)[2] for _ in range(min(BATCH, len(heap)))
                 if -heap[0][0] - best > tol * top]
        kids = np.array([kid for xa, xb, za, zb in batch
                         for kid in _quarters(xa, xb, za, zb)])
        # a square whose nearest point to q_0 is beyond e holds no master position
        near = np.hypot(np.clip(x0, kids[:, 0], kids[:, 1]) - x0,
                        np.clip(z0, kids[:, 2], kids[:, 3]) - z0)
        kids = kids[near <= e]
        up, got = bound(kids)
        best = max(best, float(got.max()))
        for u, kid in zip(up, kids, strict=True):
            count += 1
            heapq.heappush(heap, (-float(u), count, tuple(kid)))
    return WorstCase(float(max(-heap[0][0], best)), best, count)


def _quarters(xa: float, xb: float, za: float, zb: float) -> list[list[float]]:
    xm, zm = (xa + xb) / 2, (za + zb) / 2
    return [[xa, xm, za, zm], [xm, xb, za, zm], [xa, xm, zm, zb], [xm, xb, zm, zb]]


def h_amb_worst(p: Params, r0, b):
    """A lower bound of h_amb over the disks for a pair with master range r_0 and b_perp b
    (module docstring, C8): lambda sin(theta_0) (r_0^2 - e^2) / (r_0 B + e sqrt(r_0^2 + B^2 -
    e^2)) with B = b + e, the least over the master's rim of (r_0 + e cos phi) / (B + e sin
    phi); exact up to e^2 / (2 r_0) in r_0."""
    e = p.nav_error_m
    big = np.asarray(b, dtype=float) + e
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (r0**2 - e**2) / (r0 * big + e * np.sqrt(r0**2 + big**2 - e**2))
    return p.wavelength * math.sin(p.theta0) * np.where(big > 0, t, np.inf)


def _c1(p: Params, z):
    """C1 over the disks: z_k - e >= z_min and z_k + e <= z_max (exact)."""
    return np.minimum(z - p.nav_error_m - p.z_min, p.z_max - p.nav_error_m - z)


def slave_slacks(p: Params, q0: np.ndarray, xk, zk, k: int, scheme: str
                 ) -> dict[str, np.ndarray]:
    """The least slack over the disks of slave k's own families (C3, C5-C8, its C1, its C4
    with the master and its C10 station distance, this last as the station disk's radius
    less rho_k + e), vectorised over slave positions (xk, zk) (module docstring)."""
    e = p.nav_error_m
    xk, zk = np.asarray(xk, dtype=float), np.asarray(zk, dtype=float)
    r0 = float(model.slant_range(q0[0], q0[1], p.x_t))
    rk = model.slant_range(xk, zk, p.x_t)
    th, spread = model.look_angle(xk, zk, p.x_t), look_spread(e, rk)
    b = model.perpendicular_baseline(q0[0], q0[1], xk, zk, p.theta0)
    radius_sq = station_radius_sq(p, k, scheme)
    rho = np.hypot(xk - p.ground_station[0], zk - p.ground_station[2])
    return {
        "C1": _c1(p, zk),
        "C3": np.minimum(th - spread - p.theta_min, p.theta_max - th - spread),
        "C4": np.hypot(xk - q0[0], zk - q0[1]) - 2 * e - p.d_min,
        "C5": p.beamwidth * np.maximum(rk - e, 0.0) ** 2 / (zk + e) - p.swath_min,
        "C6": model.coherence_snr_at_ranges(r0 + e, rk + e, model.gamma_m(p))
        - p.coherence_snr_min,
        "C7": np.minimum(gamma_rg(p, th - spread), gamma_rg(p, th + spread))
        - p.coherence_rg_min,
        "C8": h_amb_worst(p, r0, b) - model.h_amb_min_of(p, k),
        "C10": (math.sqrt(radius_sq) if radius_sq > 0 else -math.inf) - rho,
    }


def robust_slacks(p: Params, formation: np.ndarray, p_com: np.ndarray, scheme: str
                  ) -> dict[str, ConstraintStatus]:
    """Each family's least slack over the disks (module docstring), in its SI unit; C2 (the
    master's equality) and C9, C11 (the schedule's own) are the checker's at the plan."""
    q = np.asarray(formation, dtype=float)
    e = p.nav_error_m
    uavs, slaves = active_uavs(scheme, p.num_uavs), slave_uavs(scheme, p.num_uavs)
    r0 = float(model.slant_range(q[MASTER, 0], q[MASTER, 1], p.x_t))
    own = {k: slave_slacks(p, q[MASTER], q[k, 0], q[k, 1], k, scheme) for k in slaves}
    slack: dict[str, dict[str, float]] = {
        "C1": {f"z{k}": float(_c1(p, q[k, 1])) for k in uavs},
        "C3": {f"theta{k}": float(own[k]["C3"]) for k in slaves},
        "C4": {f"d{a}{b}": float(np.hypot(*(q[a] - q[b]))) - 2 * e - p.d_min
               for i, a in enumerate(uavs) for b in uavs[i + 1:]},
        "C5": {f"S{MASTER}": p.beamwidth * (r0 - e) / math.cos(p.theta0) - p.swath_min}
        | {f"S{k}": float(own[k]["C5"]) for k in slaves},
        "C6": {f"gamma_snr{k}": float(own[k]["C6"]) for k in slaves},
        "C7": {f"gamma_rg{k}": float(own[k]["C7"]) for k in slaves},
        "C8": {f"h_amb{k}": float(own[k]["C8"]) for k in slaves},
        "C10": {},
    }
    for k in uavs:
        rho = math.hypot(q[k, 0] - p.ground_station[0], q[k, 1] - p.ground_station[2]) + e
        rate = model.fdma_rate(p_com[k], np.hypot(rho, p.y_track - p.ground_station[1]),
                               p.comm_bandwidth_hz, p.beta_c)
        slack["C10"][f"R{k}"] = float((rate - planned_rate_bps(p, k, scheme)).min())
    out = {}
    for family, values in slack.items():
        name, worst = min(values.items(), key=lambda kv: kv[1])
        out[family] = ConstraintStatus(bool(worst >= -_tolerance(p, family)), worst, name)
    return out


def _tolerance(p: Params, family: str) -> float:
    """The checker's tolerances (evaluate.py), absolute: positions to a micrometre, the rest
    relative to the family's scale."""
    from uav_insar_planner.evaluate import FEAS_TOL, POSITION_TOL_M

    scale = {"C5": max(p.swath_min, 1.0), "C8": p.h_amb_min,
             "C10": max(max(p.rate_min_bps), 1.0) * (1.0 + p.rate_margin)}.get(family, 1.0)
    return POSITION_TOL_M if family in ("C1", "C4") else FEAS_TOL * scale
