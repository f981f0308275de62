"""A deterministic feasible formation from a closed-form grid, and a feasibility test by it.

The AO's SCA steps are inner approximations, so they need a feasible start; the global back
end's infeasibility report falls back to the same grid when its search cannot decide a family
set. We build the start from the constraints of (P) themselves (exact model, no surrogate):

- the master lies on its C2 line, x_0 = x_t - z_0 tan(theta_0), z_0 on a uniform grid of
  `Z_GRID` altitudes over the part of [z_min, z_max] that C5, C6 and the station disk leave to
  the master alone (problem.master_interval; benchmark 2: the single point q0_fixed);
- each slave lies on a look-angle ray from the target, q_k = (x_t - r sin(theta), r cos(theta)),
  theta on a uniform grid of `THETA_GRID` angles over [theta_min, theta_max] (C3). On a ray every
  other constraint is an interval of r in closed form: C1, C5 (r >= S_min cos(theta)/Theta_3dB),
  C6 (r <= model.slave_range_max(r_0)), C8 (|b_perp| affine in r), C9-C11
  (power.station_radius_sq, a quadratic in r) and C4 against the master (an excluded interval).
  C7 is checked on theta.

The start is the middle of what is feasible: z_0 = the median feasible grid altitude; U1 on the
middle feasible ray with theta < theta_0 (I_a), U2 on the middle one with theta > theta_0 (I_b)
(either side when one is empty), each at the midpoint of the longest feasible r-interval on its
ray. Same input, same grid, same start.

`families` restricts the constraints to a subset of C1..C11, which is how the deletion filter
(solver/blocking.py) tests a family set; e.g. ["C1", "C5"] alone are infeasible for z_max below
the swath's altitude.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.schemes import slave_uavs
from uav_insar_planner.solver.blocking import ALL_FAMILIES
from uav_insar_planner.solver.power import station_radius_sq
from uav_insar_planner.solver.problem import c7_interval, make_problem
from uav_insar_planner.swarm import MASTER

Z_GRID = 801
THETA_GRID = 181
RAY_WINDOW = 1000.0  # metres searched along a ray beyond its lower limit


@dataclass
class Start:
    """A feasible formation ((num_uavs, 2), NaN row for an unflown UAV)."""

    formation: np.ndarray


def _ray_interval(point: np.ndarray, u: np.ndarray, centre: np.ndarray, rad_sq) -> tuple:
    """r-interval where ||point + r u - centre||^2 <= rad_sq (u unit); empty -> lo > hi."""
    w = point - centre
    b = w[0] * u[0] + w[1] * u[1]
    disc = b * b - (w[0] ** 2 + w[1] ** 2) + rad_sq
    with np.errstate(invalid="ignore"):
        s = np.sqrt(np.where(disc >= 0, disc, np.nan))
    lo = np.where(disc >= 0, -b - s, np.inf)
    hi = np.where(disc >= 0, -b + s, -np.inf)
    return lo, hi


def _master_grid(p: Params, scheme: str, fam: frozenset[str]) -> tuple[np.ndarray, np.ndarray]:
    """Candidate master positions (x0, z0) and their master-only feasibility mask."""
    if scheme == "fixed-master":
        x0, z0 = (np.array([v]) for v in p.master_fixed)
    else:
        z_lo, z_hi = ((p.z_min, p.z_max) if "C1" in fam
                      else (max(p.z_max * 1e-3, 1e-3), 10.0 * p.z_max))
        # Only the altitudes C1, C5, C6 and the station disk leave to the master alone (in
        # closed form, problem.master_interval): a grid over all of [z_min, z_max] = [1, 1e6]
        # would step 1250 m and miss Table I's feasible 47-93 m.
        sc = make_problem(p, scheme, "bound", ALL_FAMILIES - fam)
        r_lo, r_hi = sc.r0_lo, sc.r0_hi
        c0 = math.cos(p.theta0)
        if r_lo <= r_hi and max(z_lo, r_lo * c0) < min(z_hi, r_hi * c0):
            z_lo, z_hi = max(z_lo, r_lo * c0), min(z_hi, r_hi * c0)
        z0 = np.linspace(z_lo, z_hi, Z_GRID)
        x0 = model.master_x(z0, p.x_t, p.theta0)
    ok = np.ones(z0.shape, dtype=bool)
    if "C1" in fam:
        ok &= (z0 >= p.z_min) & (z0 <= p.z_max)
    if "C2" in fam:
        ok &= np.abs(x0 - model.master_x(z0, p.x_t, p.theta0)) <= 1e-9 * max(1.0, abs(p.x_t))
    r0 = model.slant_range(x0, z0, p.x_t)
    if "C5" in fam:
        ok &= model.swath_width(r0, p.theta0, p.beamwidth) >= p.swath_min
    rho2 = station_radius_sq(p, 0, scheme, ALL_FAMILIES - fam)
    gxz = np.array([p.ground_station[0], p.ground_station[2]])
    ok &= (x0 - gxz[0]) ** 2 + (z0 - gxz[1]) ** 2 <= rho2
    return np.stack([x0, z0], axis=1), ok


def _slave_pieces(p: Params, k: int, scheme: str, fam: frozenset[str], q0: np.ndarray):
    """For master q0 and slave k: thetas (T,), and per theta up to two feasible r-intervals
    (lo, hi arrays of shape (2, T)); an empty piece has lo > hi."""
    span = (p.theta_min, p.theta_max) if "C3" in fam else (math.radians(0.5), math.radians(89.5))
    if "C7" in fam:
        # C7 is an interval of look angles in closed form (Proposition 2): a narrow band
        # (B_Rg/f_0 = 3e-3) can fall between two points of a grid over all of C3
        c7_lo, c7_hi = c7_interval(make_problem(p, scheme, "bound"))
        if max(span[0], c7_lo) < min(span[1], c7_hi):
            span = (max(span[0], c7_lo), min(span[1], c7_hi))
    thetas = np.linspace(*span, THETA_GRID)
    if span[0] < p.theta0 < span[1]:
        # the master's own line of sight (b_perp = 0) is the last resort for a strict C8
        thetas = np.union1d(thetas, [p.theta0])
    u = np.stack([-np.sin(thetas), np.cos(thetas)])
    target = np.array([p.x_t, 0.0])
    lo = np.zeros_like(thetas)
    hi = np.full_like(thetas, np.inf)
    r0 = float(model.slant_range(q0[0], q0[1], p.x_t))
    if "C1" in fam:
        lo = np.maximum(lo, p.z_min / np.cos(thetas))
        hi = np.minimum(hi, p.z_max / np.cos(thetas))
    if "C5" in fam:
        lo = np.maximum(lo, p.swath_min * np.cos(thetas) / p.beamwidth)
    if "C6" in fam:
        hi = np.minimum(hi, model.slave_range_max(p, r0))
    if "C7" in fam:
        bp = p.fractional_bandwidth
        g_rg = model.coherence_baseline(model.chi(p.theta0, thetas), bp)
        hi = np.where(g_rg >= p.coherence_rg_min, hi, -np.inf)
    if "C8" in fam:
        # b_perp = |c0 + r sin(theta_0 - theta)| (eq. 3 projected on the LOS normal)
        bmax = model.baseline_max(p, r0, k)  # slave k's own C8 rung
        c0 = (p.x_t - q0[0]) * math.cos(p.theta0) - q0[1] * math.sin(p.theta0)
        s = np.sin(p.theta0 - thetas)
        with np.errstate(divide="ignore", invalid="ignore"):
            a, b = (-bmax - c0) / s, (bmax - c0) / s
        flat = np.abs(s) < 1e-12
        lo = np.maximum(lo, np.where(flat, np.where(abs(c0) <= bmax, -np.inf, np.inf),
                                     np.minimum(a, b)))
        hi = np.minimum(hi, np.where(flat, np.inf, np.maximum(a, b)))
    rho2 = station_radius_sq(p, k, scheme, ALL_FAMILIES - fam)
    if rho2 < math.inf:
        gxz = np.array([p.ground_station[0], p.ground_station[2]])
        dlo, dhi = _ray_interval(target[:, None], u, gxz[:, None], rho2)
        lo, hi = np.maximum(lo, dlo), np.minimum(hi, dhi)
    # a finite search window when nothing bounds r from above (families removed)
    hi = np.minimum(hi, lo + RAY_WINDOW)
    los, his = np.stack([lo, lo]), np.stack([hi, hi])
    if "C4" in fam:
        elo, ehi = _ray_interval(target[:, None], u, q0[:, None], p.d_min**2)
        his[0] = np.minimum(hi, elo)  # below the master's excluded disk
        los[1] = np.maximum(lo, ehi)  # above it
        # the disk misses the ray: keep one piece only
        miss = ~np.isfinite(elo)
        his[0] = np.where(miss, hi, his[0])
        los[1] = np.where(miss, np.inf, los[1])
    return thetas, los, his


def _ray_points(p: Params, thetas, los, his) -> tuple[np.ndarray, np.ndarray]:
    """Per theta: the midpoint of the longest feasible piece (x, z) and a feasibility mask."""
    length = his - los
    best = np.argmax(np.where(length >= 0, length, -np.inf), axis=0)
    idx = np.arange(thetas.size)
    lo, hi = los[best, idx], his[best, idx]
    ok = (hi >= lo) & np.isfinite(lo) & np.isfinite(hi)
    with np.errstate(invalid="ignore"):
        r = np.where(ok, 0.5 * (lo + hi), np.nan)
    pts = np.stack([p.x_t - r * np.sin(thetas), r * np.cos(thetas)], axis=1)
    return pts, ok


def _middle(indices: np.ndarray) -> int:
    return int(indices[(indices.size - 1) // 2])


def _pick_slaves(p: Params, slaves: tuple[int, ...], q0: np.ndarray,
                 candidates: dict) -> dict | None:
    """Slave positions for master q0, or None. Preferred sides alternate: U1, U3, U5 in I_a,
    U2, U4 in I_b."""
    chosen: dict[int, np.ndarray] = {}
    for k in slaves:
        thetas, pts, ok = candidates[k]
        side = (thetas < p.theta0) if k % 2 else (thetas > p.theta0)
        pool = np.flatnonzero(ok & side)
        if pool.size == 0:
            pool = np.flatnonzero(ok)
        if pool.size == 0:
            return None
        # middle first, then outwards, until C4 to the slaves already placed holds
        mid = (pool.size - 1) // 2
        order = sorted(range(pool.size), key=lambda i: (abs(i - mid), i))
        for i in order:
            q = pts[pool[i]]
            if all(np.hypot(*(q - other)) >= p.d_min for other in chosen.values()):
                chosen[k] = q
                break
        else:
            return None
    return chosen


def find_start(p: Params, scheme: str, families: Iterable[str] = ALL_FAMILIES,
               first: bool = False) -> Start | None:
    """A feasible start for `scheme` under the constraint `families`, or None (see module).
    `first` stops at the first feasible master altitude (an existence test)."""
    fam = frozenset(families)
    masters, mok = _master_grid(p, scheme, fam)
    slaves = slave_uavs(scheme, p.num_uavs)
    if "C4" not in fam:
        p = dataclasses.replace(p, d_min=0.0)  # keeps energy_budget_uav_j (replace drops it)
    feasible: list[tuple[int, dict]] = []
    for i in np.flatnonzero(mok):
        cands = {}
        for k in slaves:
            thetas, los, his = _slave_pieces(p, k, scheme, fam, masters[i])
            pts, ok = _ray_points(p, thetas, los, his)
            cands[k] = (thetas, pts, ok)
        if all(cands[k][2].any() for k in slaves):
            chosen = _pick_slaves(p, slaves, masters[i], cands)
            if chosen is not None:
                feasible.append((int(i), chosen))
                if first:
                    break
    if not feasible:
        return None
    i, chosen = feasible[_middle(np.arange(len(feasible)))]
    formation = np.full((p.num_uavs, 2), np.nan)
    formation[MASTER] = masters[i]
    for k, q in chosen.items():
        formation[k] = q
    return Start(formation)
