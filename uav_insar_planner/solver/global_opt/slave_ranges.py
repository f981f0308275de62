"""The slaves' best ranges for given look angles, and interval bounds over boxes of angles.

All three objectives are sigma = lambda r0 sin(theta_0) / (2 pi sqrt(sum_k w_k)) with
w_k = b_perp,k^2 / sigma_Phi,k^2 (rays.weight). For fixed (r0, theta_k), w_k is increasing in
the slave range r: b_perp = r |sin(theta - theta_0)| grows linearly, and for `exact`, with
s = r0^2 r / gamma_m and gamma = K / sqrt(1 + s) (K < 1 collects gamma_Rg, the master's SNR
factor and gamma_other), sigma_Phi^2 / r^2 is proportional to ((1 + s)/K^2 - 1) / s^2, whose
derivative in s is (2 - (2 + s)/K^2) / s^3 < 0. For `multilook`, d log w / d log r =
2 - e s / (1 + s), e = -d log sigma_Phi / d log gamma = 2 (d log sigma_Phi / dv) / (1 - gamma^2),
v = log((1 - gamma^2) / gamma^2); as gamma^2 < 1 / (1 + s), s / (1 + s) < 1 - gamma^2, so
e s / (1 + s) < 2 d log sigma_Phi / dv < 2 (the slope is < 1, checked on every table in
multilook.py; Cramer-Rao's is 1/2). So each slave wants the top of its feasible
set on its ray, and the slaves interact only through C4 between themselves:
||q_1 - q_2||^2 = r_1^2 + r_2^2 - 2 c r_1 r_2 with c = cos(theta_1 - theta_2), an ellipse E
about the origin of the (r_1, r_2) plane that the pair must avoid.

Pareto argument (used by both the exact inner solve and the box bound): on a box
J_1 x J_2 of ranges, a feasible point P outside E stays outside E when scaled by t >= 1 (E is
convex and centred at 0), so t P reaches the top edge or the right edge of the box while
staying feasible and dominating P. On the right edge r_1 = top_1 the best r_2 is top_2 if
(top_1, top_2) is outside E, else the lower crossing of E, y_lo(top_1). Hence the optimum over
J_1 x J_2 is among (top_1, top_2), (top_1, y_lo(top_1)), (x_lo(top_2), top_2).
"""
from __future__ import annotations

import math

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.solver import rays
from uav_insar_planner.solver.global_opt.kernel import (
    lower_crossing,
    objective_from_normalised,
    range_components,
    slave_weight,
)
from uav_insar_planner.solver.problem import HALF_PI, Problem, angle_between, disk_at_psi


def best_ranges(sc: Problem, r0, th1, th2=None):
    """Exact optimum of the slave ranges for fixed (r0, theta_1[, theta_2]). With one slave
    (sc.slaves == (k,)) theta_1 is that slave's angle.

    Returns (objective, r1, r2): objective +inf and ranges nan where no ranges are feasible,
    and at r0 = 0 (the master on the target: no look angle, no baseline).
    """
    r0 = np.asarray(r0, dtype=float)
    th1 = np.asarray(th1, dtype=float)
    comps1 = range_components(sc, sc.slaves[0], r0, th1)
    if len(sc.slaves) == 1:
        lo_b, top_b = comps1[1]
        lo_a, top_a = comps1[0]
        r1 = np.where(lo_b <= top_b, top_b, np.where(lo_a <= top_a, top_a, np.nan))
        w = slave_weight(sc, r0, th1, r1)
        f = np.where(np.isfinite(r1) & (w > 0) & (r0 > 0), objective_from_normalised(sc, w), np.inf)
        return f, r1, np.full_like(r1, np.nan)
    th2 = np.asarray(th2, dtype=float)
    comps2 = range_components(sc, sc.slaves[1], r0, th2)
    c = np.cos(th1 - th2)
    d2 = sc.p.d_min**2 if sc.on("C4") else 0.0
    best_w = np.full(np.broadcast(r0, th1, th2).shape, -np.inf)
    best_r1 = np.full_like(best_w, np.nan)
    best_r2 = np.full_like(best_w, np.nan)

    def consider(ok, w, r1, r2):
        nonlocal best_w, best_r1, best_r2
        take = ok & (w > best_w)
        best_w = np.where(take, w, best_w)
        best_r1 = np.where(take, r1, best_r1)
        best_r2 = np.where(take, r2, best_r2)

    g1, g2 = rays.coherence_rg(sc, th1), rays.coherence_rg(sc, th2)
    with np.errstate(invalid="ignore"):
        tops1 = [(lo, t, slave_weight(sc, r0, th1, t, g1)) for lo, t in comps1]
        tops2 = [(lo, t, slave_weight(sc, r0, th2, t, g2)) for lo, t in comps2]
        for lo1, t1, w1 in tops1:
            for lo2, t2, w2 in tops2:
                valid = (lo1 <= t1) & (lo2 <= t2)
                clear = t1 * t1 + t2 * t2 - 2.0 * c * t1 * t2 >= d2
                consider(valid & clear, w1 + w2, t1, t2)
                crowded = valid & ~clear
                if not crowded.any():
                    continue
                y = lower_crossing(t1, c, d2)
                ok = crowded & (y >= lo2)
                consider(ok, w1 + slave_weight(sc, r0, th2, np.where(ok, y, t2), g2), t1, y)
                x = lower_crossing(t2, c, d2)
                ok = crowded & (x >= lo1)
                consider(ok, slave_weight(sc, r0, th1, np.where(ok, x, t1), g1) + w2, x, t2)
    f = np.where((best_w > 0) & (r0 > 0), objective_from_normalised(sc, best_w), np.inf)
    return f, best_r1, best_r2


# --- interval bounds over boxes ------------------------------------------------------------

def _nearest(v, a, b):
    return np.clip(v, a, b)


def abs_sin_range(dlo, dhi):
    """(min, max) of |sin(delta)| over [dlo, dhi] with |delta| < pi."""
    s_lo, s_hi = np.abs(np.sin(dlo)), np.abs(np.sin(dhi))
    smin = np.where((dlo <= 0.0) & (dhi >= 0.0), 0.0, np.minimum(s_lo, s_hi))
    peak = ((dlo <= HALF_PI) & (dhi >= HALF_PI)) | (
        (dlo <= -HALF_PI) & (dhi >= -HALF_PI))
    smax = np.where(peak, 1.0, np.maximum(s_lo, s_hi))
    return smin, smax


def slave_box(sc: Problem, k: int | tuple[int, ...], r0a, r0b, ta, tb):
    """Bounds for slave k over the box r0 in [r0a, r0b], theta in [ta, tb]: a lower bound on
    its range's lower limit, an upper bound on its upper limit, and the pieces of the weight
    bound (see weight_bound). Each limit is monotone in r0 and in |theta|, |theta - theta_0| or
    the angle to the station (rays), so its extreme over the box sits at a known corner.

    k a tuple of slaves: ta, tb (len(k), n), one row per slave, all rows in one pass."""
    p = sc.p
    if isinstance(k, tuple):
        disk_r2 = np.array([sc.disk_r2[i] for i in k])[:, None]
        b_lim = np.stack([np.broadcast_to(rays.baseline_limit(sc, r0b, i), np.shape(r0b))
                          for i in k])
    else:
        disk_r2, b_lim = sc.disk_r2[k], rays.baseline_limit(sc, r0b, k)
    abs_a, abs_b = np.abs(ta), np.abs(tb)
    abs_lo = np.where((ta <= 0) & (tb >= 0), 0.0, np.minimum(abs_a, abs_b))
    cos_hi = np.cos(np.maximum(abs_a, abs_b))
    if np.any(np.asarray(disk_r2) != math.inf):  # an infinite disk gives (-inf, inf)
        ra, rb = disk_at_psi(sc, disk_r2,
                             angle_between(_nearest(sc.station_angle, ta, tb), sc.station_angle))
        lo, up = np.maximum(ra, 0.0), rb
    else:
        lo, up = np.zeros_like(ta), np.full_like(ta, math.inf)
    if sc.on("C1"):
        lo = np.maximum(lo, p.z_min / np.cos(abs_lo))
        up = np.minimum(up, p.z_max / cos_hi)
    if sc.on("C5"):
        lo = np.maximum(lo, p.swath_min * cos_hi / p.beamwidth)
    up = np.minimum(up, rays.snr_limit(sc, r0a))
    smin, smax = abs_sin_range(ta - sc.th0, tb - sc.th0)
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.minimum(up, np.where(smin > 0, b_lim / smin, math.inf))
    if sc.on("C4"):
        up = _below_master_hole(sc, r0a, r0b, ta, tb, lo, up)
    g_rg = rays.coherence_rg(sc, _nearest(sc.th0, ta, tb))
    return lo, up, smax, g_rg


def _below_master_hole(sc: Problem, r0a, r0b, ta, tb, lo, up):
    """The range limit `up` lowered past the master's C4 hole where the hole covers it for every
    point of the box (-inf: the slave cannot be there at all); see master_hole_box."""
    h1, h2 = _master_hole_box(sc, r0a, r0b, ta, tb)
    if h1 is None:
        return up
    covered = (up > h1) & (up < h2)
    return np.where(covered, np.where(h1 >= lo, h1, -np.inf), up)


def master_hole_box(sc: Problem, r0a, r0b, ta, tb):
    """(H1, H2): ranges in (H1, H2) are closer than d_min to the master (C4) at every point of
    the box; (inf, -inf) when no range is, or C4 is off.

    On ray theta the hole is (h1, h2) = r0 cos(delta) -/+ sqrt(d_min^2 - r0^2 sin^2(delta)),
    delta = theta - theta_0. Over the box, with |delta| < pi/2, h1 <= H1 = r0b cos(delta_min) -
    sqrt(d_min^2 - (r0b sin(delta_max))^2) and h2 >= H2 = r0a cos(delta_max) +
    sqrt(d_min^2 - (r0b sin(delta_max))^2) (each term at its extreme; h1 grows with r0), and
    the hole exists everywhere when r0b sin(delta_max) < d_min. At a point box H1, H2 are the
    hole itself."""
    h1, h2 = _master_hole_box(sc, r0a, r0b, ta, tb)
    if h1 is None:
        shape = np.broadcast(r0a, ta).shape
        return np.full(shape, np.inf), np.full(shape, -np.inf)
    return h1, h2


def _master_hole_box(sc: Problem, r0a, r0b, ta, tb):
    """master_hole_box, with (None, None) when no box has a hole (most, at small d_min)."""
    if not sc.on("C4"):
        return None, None
    ta, tb = np.asarray(ta, dtype=float), np.asarray(tb, dtype=float)
    dhi = np.maximum(np.abs(ta - sc.th0), np.abs(tb - sc.th0))
    disc = sc.p.d_min**2 - (r0b * np.sin(np.minimum(dhi, HALF_PI))) ** 2
    exists = (disc > 0.0) & (dhi < HALF_PI)
    if not exists.any():
        return None, None
    dlo = np.where((ta <= sc.th0) & (tb >= sc.th0), 0.0,
                   np.minimum(np.abs(ta - sc.th0), np.abs(tb - sc.th0)))
    root = np.sqrt(np.maximum(disc, 0.0))
    return (np.where(exists, r0b * np.cos(dlo) - root, np.inf),
            np.where(exists, r0a * np.cos(dhi) + root, -np.inf))


def c8_cap(sc: Problem, k: int) -> float:
    """Slave k's C8 cap on b_perp / r0, lambda sin(theta_0) / h_amb,k^min (its own rung of
    h_amb_ratio's ladder, free of r0); +inf when C8 is off."""
    return float(model.baseline_max(sc.p, 1.0, k)) if sc.on("C8") else math.inf


def capped_weight_bound(sc: Problem, r0a, ta, tb, cap):
    """Upper bound on w / r0^2 for a slave with C8 cap `cap` (c8_cap) at every feasible point of
    the box r0 >= r0a > 0, theta in [ta, tb]; +inf where the proof below does not apply.

    Proof. C8 is r |sin(delta)| <= cap r0, delta = theta - theta_0, and w / r0^2 is
    non-decreasing in r (module docstring), so w / r0^2 <= V(r0, theta) = weight(cap, gamma_Rg,
    gamma_SNR(r0, cap r0 / sin|delta|)) = cap^2 F(g), g = gamma_Rg(theta) gamma_SNR, F
    increasing. gamma_SNR falls with r0 (directly and through the range): take r0a. With
    kappa = cap r0a^3 / gamma_m, log gamma_SNR = const - log(1 + kappa / sin|delta|) / 2, whose
    slope in |delta| is kappa cos / (2 sin (sin + kappa)) > 0, decreasing on (0, pi/2]: concave
    in theta on either side of theta_0. gamma_Rg = 1 - 2 y / B_p (eqs. 10-11) with
    y = (s_0 - s) / (3 s_0 + s) below theta_0 and y = (s - s_0) / (s_0 + 3 s) above (s = sin
    theta, s_0 = sin theta_0), and (log(1 - c y))'' = -c y'' / g_Rg - (c y' / g_Rg)^2, c = 2 / B_p.
    Below: y'' = 4 s_0 (s (3 s_0 + s) + 2 cos^2) / (3 s_0 + s)^3 >= 0 for theta in [0, pi/2).
    Above: y'' = -4 s_0 (s (s_0 + 3 s) + 6 cos^2) / (s_0 + 3 s)^3 and g_Rg <= 1, so
    |y''| <= c y'^2, i.e. (s (s_0 + 3 s) + 6 cos^2)(s_0 + 3 s) <= 4 c s_0 cos^2, suffices; it is
    checked once over the whole slave domain above theta_0 (_concave_above; it must lie in
    [0, pi/2)). So L = log(gamma_Rg gamma_SNR) is concave on [ta, tb] where the box lies on one
    side of theta_0 within [0, pi/2) (above: within [theta_0, th_hi]), gamma_Rg > 0 at both
    ends (so throughout: it is monotone on each side), and (above) the check passes. A
    concave L lies below its tangents at ta and tb, hence max L <= L(ta) if L'(ta) <= 0,
    L(tb) if L'(tb) >= 0, else the tangents' crossing."""
    s0, c, th0 = sc.sin0, 2.0 / sc.bp, sc.th0
    below = (tb < th0) & (ta >= 0.0)
    ok = below | ((ta > th0) & (tb <= sc.th_hi)) if _concave_above(sc) else below
    side = np.where(below, -1.0, 1.0)  # d|delta| / d theta
    ends = np.stack([ta, tb])  # both ends in one pass
    s, cos = np.sin(ends), np.cos(ends)
    sd, cd = side * np.sin(ends - th0), np.cos(ends - th0)  # sin, cos of |delta|
    u = side * (s - s0)  # y = u / den, den = 3 s_0 + s below, s_0 + 3 s above
    den = 2.0 * (s + s0) + u
    g_rg = 1.0 - c * u / den
    kappa = cap * r0a**3 / sc.gm
    with np.errstate(divide="ignore", invalid="ignore"):
        ell = 0.5 * np.log(g_rg * g_rg * sd / (sd + kappa))  # log gamma_Rg + log gamma_SNR + const
        slope = side * (0.5 * kappa * cd / (sd * (sd + kappa))
                        - 4.0 * c * s0 * cos / (den * den * g_rg))
        (la, lb), (da, db) = ell, slope
        cross = la + da * (lb - la - db * (tb - ta)) / (da - db)
        top = np.where(da <= 0.0, la, np.where(db >= 0.0, lb, cross))
        g = np.exp(top) / np.sqrt(1.0 + r0a**3 / sc.gm)  # gamma_Rg gamma_SNR
    ok &= (np.minimum(g_rg[0], g_rg[1]) > 0.0) & (g * sc.p.coherence_other < 1.0) & (r0a > 0)
    return np.where(ok, rays.weight(sc, cap, np.where(ok, g, 0.5), 1.0), math.inf)


def _concave_above(sc: Problem) -> bool:
    """capped_weight_bound's check above theta_0 over the whole domain [theta_0, th_hi] (s and
    cos are monotone there, so it holds on every box inside)."""
    s0, c = sc.sin0, 2.0 / sc.bp
    if not sc.th0 < sc.th_hi < HALF_PI:
        return False
    sb, ca, cb = math.sin(sc.th_hi), math.cos(sc.th0), math.cos(sc.th_hi)
    return (sb * (s0 + 3.0 * sb) + 6.0 * ca * ca) * (s0 + 3.0 * sb) <= 4.0 * c * s0 * cb * cb


def weight_bound(sc: Problem, r0a, rho, smax, g_rg, cap):
    """Upper bound on w / r0^2 for any point of the box whose slave range is at most rho.

    b_perp / r0 <= min(r smax / r0a, cap), cap = lambda sin(theta_0) / h_amb,k^min the slave's
    C8 (`c8_cap`, free of r0; per slave, broadcast with rho), and sigma_Phi >=
    sigma_Phi(g_rg_max gamma_SNR(r0a, r)). Uncapped, the bound grows with r (module docstring);
    capped, it falls with r. So its maximum over r <= rho is at min(rho, r_cap): the result is
    non-decreasing in rho, as the Pareto argument needs."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.minimum(rho, np.where(smax > 0, cap * r0a / smax, math.inf))
        bn = np.where(smax > 0, np.minimum(r * smax / r0a, cap), 0.0)
        w = rays.weight(sc, bn, g_rg, rays.snr_factor(sc, r0a, r))
        # A box reaching r0 = 0: b_perp / r0 <= cap (C8) and gamma_SNR <= 1 still bound it.
        at_zero = np.asarray(r0a) <= 0
        if at_zero.any():
            w = np.where(at_zero, rays.weight(sc, np.where(smax > 0, cap, 0.0), g_rg, 1.0), w)
    # An unbounded range (only with constraint families switched off) has unbounded weight.
    return np.where(np.isnan(w), np.inf, w)


def pair_weight_bound(sc: Problem, r0a, one, two, w_one, w_two,
                      caps: tuple[float, float]):
    """Upper bound on w_i / r0^2 + w_j / r0^2 over a box for two slaves kept d_min apart (C4),
    -inf where the pair provably has no feasible point. `one` and `two` are
    (lo, up, smax, g_rg, theta_a, theta_b): slave_box's pieces and the angle interval; w_one
    and w_two their weight_bound at `up` (the single-slave bounds, computed once); caps the
    two slaves' C8 caps (c8_cap).

    C4 is kept through the ellipse with c_max = cos of the box's largest angle difference,
    which contains the true exclusion ellipse of every angle pair in it; by the Pareto argument
    the pair's best is at (up_1, up_2) when that is outside, else at (up_1, y_lo(up_1)) or
    (x_lo(up_2), up_2)."""
    lo1, up1, s1, g1, t1a, t1b = one
    lo2, up2, s2, g2, t2a, t2b = two
    w_top = w_one + w_two
    if not sc.on("C4"):
        return w_top
    dmax = np.minimum(np.maximum(np.abs(t1b - t2a), np.abs(t2b - t1a)), math.pi)
    c = np.cos(dmax)
    d2 = sc.p.d_min**2
    with np.errstate(invalid="ignore"):
        inside = up1 * up1 + up2 * up2 - 2.0 * c * up1 * up2 < d2
        if not inside.any():  # the tops are d_min apart in every box
            return w_top
        y = lower_crossing(up1, c, d2)
        x = lower_crossing(up2, c, d2)
        # slave 2 at y below slave 1's top, slave 1 at x below slave 2's: one call for both
        w_yx = weight_bound(sc, r0a, np.maximum(np.stack([y, x]), 0.0), np.stack([s2, s1]),
                            np.stack([g2, g1]), np.array([[caps[1]], [caps[0]]]))
        wa = np.where(y >= lo2, w_one + w_yx[0], -np.inf)
        wb = np.where(x >= lo1, w_yx[1] + w_two, -np.inf)
    return np.where(inside, np.maximum(wa, wb), w_top)
