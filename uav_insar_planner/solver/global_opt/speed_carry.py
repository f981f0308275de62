"""What a step in the survey speed v_y carries from one certified solve to the next.

A speed front (survey/speed.py) solves (P) at v, then at v'. v_y enters the ray model only
through gamma_m = K / v_y (C6 and the objective) and the station disk of C9-C11 (warm.py).
The previous search ends with boxes B of (r0, theta_1, ..., theta_K) that cover its domain,
each with lb(B), a lower bound proven at v of sigma_h(.; v) over F(v) ∩ B, its feasible
points. `carried` proves, box by box,

    sigma_h(x; v') >= rho_B lb(B)    for every x in F(v') ∩ B,    rho_B > 0,

and `boxes` lays out the next search's first boxes with them.

1. Pareto points. For fixed (r0, angles) each slave's weight w_k rises with its range
   (slave_ranges.py), so the minimum of sigma_h over F(v') ∩ B is attained at points whose
   ranges are the tops of the slaves' feasible intervals or, for a pair closer than d_min, one
   slave's top and the other at the lower crossing of their C4 ellipse (slave_ranges.best_ranges,
   K <= 2), y_lo(t) = t c - sqrt(d_min^2 - t^2 (1 - c^2)) >= t c - d_min, c = cos(theta_1 -
   theta_2). Over B a top is at least T_k, every upper range limit of the ray model at its
   least favourable corner of B, unless the master's C4 hole may lie on a slave's ray
   (r0a min|sin(theta - theta_0)| < d_min: a top may then be the hole's lower edge). So a
   Pareto point's range r_k >= R_k = min(T_k, c_min T_j - d_min) (K = 2 with C4; T_k alone
   otherwise; 0 where a hole may lie), c_min the cosine of the box's largest angle difference;
   and r_k <= U_k, every upper limit at its most favourable corner (slave_ranges.slave_box).

2. They lie in F(v). Only C6 and the disk differ. A step that restricts (P)
   (warm.speed_restricts) needs no test. Otherwise each slave's ranges [R_k, U_k] must meet
   v's C6 limit, U_k <= r_max(r0b; gamma_m(v)) (it falls with r0), and v's disk,
   r_a(psi_max) <= R_k and U_k <= r_b(psi_max), psi the ray's angle to the station
   (problem.disk_at_psi: r_a rises and r_b falls with psi where the ray meets the disk). The
   master's limits are the domain of r0, and B lies in v's domain. A box that fails is
   bounded afresh.

3. The ratio (`exact`). sigma_h = lambda r0 sin(theta_0) / (2 pi sqrt(sum_k w_k)) with
   w_k = b_k^2 2 n_L C_k^2 / (u_k - C_k^2), C_k = gamma_Rg gamma_other <= 1 and
   u_k = 1 / gamma_SNR^2 = (1 + a / gamma_m)(1 + b_k / gamma_m) > 1, a = r0^3, b_k = r0^2 r_k.
   At a fixed point w_k(v) / w_k(v') = t_k = (u'_k - C_k^2) / (u_k - C_k^2), and

       sigma_h(x; v')^2 / sigma_h(x; v)^2 = sum_k w_k(v) / sum_k w_k(v') >= min_k t_k.

   With alpha = 1 + a / gamma_m, beta = 1 + b / gamma_m (primed: gamma_m'), for a step up
   (gamma_m' <= gamma_m, so u' >= u):
   d t / d C^2 = (u' - u) / (u - C^2)^2 >= 0;
   d t / d b has the sign of alpha alpha' (1/gamma_m' - 1/gamma_m) - C^2 (alpha'/gamma_m' -
   alpha/gamma_m) >= (alpha' - alpha) a / (gamma_m gamma_m') >= 0 (the bracket is >= 0 and
   C^2 <= 1); d t / d a likewise, with beta for alpha and b for a. So t is smallest at the
   least a, b and C^2 of the box: a = r0a^3, b = r0a^2 R_k, C^2 at the end of [theta_a,
   theta_b] farther from theta_0 (gamma_Rg falls with |theta - theta_0| on both sides). For a
   step down every sign flips: t is smallest at a = r0b^3, b = r0b^2 U_k (b -> inf:
   t -> alpha' gamma_m / (alpha gamma_m')) and the largest C^2. rho_B = sqrt(min_k of it).
   `bound` does not read gamma_m: rho_B = 1. `multilook` (its phase std falls with the
   coherence too) is carried up in speed only, where sigma_h does not fall: rho_B = 1.

For a Pareto point x of F(v') ∩ B, x is in F(v) ∩ B (2), so sigma_h(x; v') >= rho_B
sigma_h(x; v) >= rho_B lb(B) (3), and the minimum over F(v') ∩ B is at such points (1). A box
proven empty at v holds no Pareto point at v' (2; a non-empty F(v') ∩ B has one), so it stays
empty. Either way of the step; only K <= 2 slaves are carried (the chain of K >= 3 has other
Pareto points).

Boxes (`boxes`). Where the optimum slides with v (Table I below 2.75 m/s: the slaves' angles
move 3-5 mrad a 0.25 m/s step, inside a near-optimal set the previous search had to cut
finely, sigma_h being only quadratically above its minimum there), the previous boxes are
moved by d, the warm incumbent's (r0, angles) less the previous optimum's, and cut to the new
domain D', and the strips of D' beyond the moved domain, {y in D' : y_i < a_i + d_i} and
{y in D' : y_i > b_i + d_i}, are added: a point y of D' in no strip has y - d in the old
domain prod_i [a_i, b_i], ordered when y is (d is one shift for interchangeable slaves), so it
lies in a moved box. Every bound is then computed afresh: the boxes only lay the search out
as the previous certificate needed it. The optimum has moved when d leaves, in some
coordinate, the finest box of the core (boxes within FINE of the finest whose bounds are
within NEAR of the least); else the boxes stay in place (D' inside the old domain) with
their bounds carried. A carried bound costs about a third to a whole fresh one (the tests
read as many range limits as the bound), so carrying pays where most boxes close on it
unsplit (Table I past 3 m/s, the optimum at theta_max), and moving where the certificate's
fine boxes follow the optimum.
"""
from __future__ import annotations

import math

import numpy as np

from uav_insar_planner.solver import rays
from uav_insar_planner.solver.global_opt import slave_ranges
from uav_insar_planner.solver.problem import Problem, disk_at_psi

# The core (_moves): boxes at most FINE times the finest (relative to the domain's widths)
# with bounds within NEAR (relative) of the least: about 5 500 boxes of Table I's flat
# optimum at 1-2.5 m/s, whose finest are 5e-5 rad wide in the angles.
FINE = 8.0
NEAR = 3e-4
# More boxes than these are not carried to the next speed, which starts from the root's
# split instead: in place (as LEAVES_MAX of warm.py for other sweeps), or moved (every bound
# afresh; Table I's searches end with 9 000-10 400 boxes at 1-2.25 m/s, and a moved
# partition keeps growing, by ~1 300 boxes a 0.25 m/s step: 12 000 and 10 000 took 1.1x and
# 1.2x the time of 16 384 over the benchmark's front).
CARRIED_MAX = 8192
MOVED_MAX = 16384


def carried(before: Problem, sc: Problem, boxes: np.ndarray, lb: np.ndarray,
            restricted: bool) -> np.ndarray:
    """rho_B lb(B) for each box (module docstring), -inf where it is not proven. `before` and
    sc differ in the speed alone; restricted: sc restricts before (warm.speed_restricts)."""
    out = np.full(len(boxes), -np.inf)
    up = sc.gm <= before.gm  # a step up in speed: sigma_h rises at every point
    if len(sc.slaves) > 2 or (sc.objective == "multilook" and not up) or not len(boxes):
        return out
    r0a, r0b = boxes[:, 0], boxes[:, 1]
    if np.any(r0a <= 0.0):
        return out
    rays_ = [_Rays(sc, boxes[:, 2 + 2 * j], boxes[:, 3 + 2 * j]) for j in range(len(sc.slaves))]
    least = [ray.top(sc, k, r0a, r0b, True) for ray, k in zip(rays_, sc.slaves, strict=True)]
    most = ([ray.top(sc, k, r0a, r0b, False) for ray, k in zip(rays_, sc.slaves, strict=True)]
            if not (restricted and up) else least)
    lows = least
    if len(sc.slaves) == 2 and sc.on("C4"):
        (a1, b1), (a2, b2) = ((ray.ta, ray.tb) for ray in rays_)
        c_min = np.cos(np.minimum(np.maximum(np.abs(b1 - a2), np.abs(b2 - a1)), math.pi))
        d = sc.p.d_min
        lows = [np.minimum(least[0], c_min * least[1] - d),
                np.minimum(least[1], c_min * least[0] - d)]
    if sc.on("C4"):  # the master's hole may lie on a ray: a top may be its lower edge
        hole = r0a * np.minimum.reduce([ray.smin for ray in rays_]) < sc.p.d_min
        lows = [np.where(hole, 0.0, low) for low in lows]
    lows = [np.maximum(low, 0.0) for low in lows]
    ok = np.ones(len(boxes), dtype=bool)
    if not restricted:
        for ray, k, low, top in zip(rays_, sc.slaves, lows, most, strict=True):
            ok &= ray.before_holds(before, k, r0b, low, top)
    if sc.objective != "exact":
        return np.where(ok, lb, -np.inf)  # rho_B = 1 (and lb holds where restricting)
    ratio = np.minimum.reduce([
        ray.ratio(before, sc, r0a, low, True) if up else ray.ratio(before, sc, r0b, top, False)
        for ray, low, top in zip(rays_, lows, most, strict=True)])
    rho = np.sqrt(np.maximum(ratio, 0.0))
    ok &= (ratio > 0.0) | np.isinf(lb)  # an empty box needs no ratio
    out = np.where(ok, np.where(np.isinf(lb), lb, rho * lb), -np.inf)
    # restricting: lb itself holds at v' (warm.py), whatever rho_B
    return np.maximum(out, lb) if restricted else out


class _Rays:
    """One slave's angle intervals [ta, tb] of the boxes, with what every test reads of them
    (look angles stay inside (-pi/2, pi/2), so an angle difference needs no wrapping)."""

    def __init__(self, sc: Problem, ta: np.ndarray, tb: np.ndarray):
        self.ta, self.tb = ta, tb
        self.smin, self.smax = slave_ranges.abs_sin_range(ta - sc.th0, tb - sc.th0)
        psi_a, psi_b = np.abs(ta - sc.station_angle), np.abs(tb - sc.station_angle)
        self.psi_far = np.maximum(psi_a, psi_b)
        self.psi_near = np.where((ta <= sc.station_angle) & (sc.station_angle <= tb), 0.0,
                                 np.minimum(psi_a, psi_b))

    def top(self, sc: Problem, k: int, r0a, r0b, least: bool) -> np.ndarray:
        """Slave k's top range over each box at its least favourable corner (every upper
        limit of rays.ray_limits at its smallest over the box), else its most favourable
        (slave_ranges.slave_box's `up`, without the master's hole); -inf where none."""
        p, ta, tb = sc.p, self.ta, self.tb
        top = np.full(np.shape(ta), math.inf)
        if sc.disk_r2[k] != math.inf:
            top = disk_at_psi(sc, sc.disk_r2[k], self.psi_far if least else self.psi_near)[1]
        if sc.on("C1"):
            abs_th = (np.where((ta <= 0) & (tb >= 0), 0.0, np.minimum(np.abs(ta), np.abs(tb)))
                      if least else np.maximum(np.abs(ta), np.abs(tb)))
            top = np.minimum(top, p.z_max / np.cos(abs_th))
        top = np.minimum(top, rays.snr_limit(sc, r0b if least else r0a))
        if sc.on("C8"):
            sin = self.smax if least else self.smin
            cap = rays.baseline_limit(sc, r0a if least else r0b, k)
            top = np.minimum(top, np.divide(cap, sin, out=np.full(np.shape(ta), math.inf),
                                            where=sin > 0))
        return top

    def before_holds(self, before: Problem, k: int, r0b, low, up) -> np.ndarray:
        """Do ranges in [low, up] on every ray of the boxes meet the previous point's C6 and
        station disk (module docstring, 2)?"""
        ok = up <= rays.snr_limit(before, r0b)
        if before.disk_r2[k] != math.inf:
            r_a, r_b = disk_at_psi(before, before.disk_r2[k], self.psi_far)
            ok &= (r_a <= low) & (up <= r_b)
        return ok

    def ratio(self, before: Problem, sc: Problem, r0, r, up: bool) -> np.ndarray:
        """t = (u' - C^2) / (u - C^2) at its minimum over the boxes (module docstring, 3):
        at r0 and range r, which are r0a and the least range for a step up, else r0b and the
        largest (maybe inf), with C^2 at its least over [ta, tb] for a step up, else its
        largest; u from `before`'s gamma_m, u' from sc's; -inf where u <= C^2."""
        g_far = np.minimum(rays.coherence_rg(sc, self.ta), rays.coherence_rg(sc, self.tb))
        if up:
            c2 = np.maximum(g_far, 0.0) ** 2
        else:
            g_near = rays.coherence_rg(sc, np.clip(sc.th0, self.ta, self.tb))
            c2 = np.maximum(g_near**2, g_far**2)
        c2 = c2 * sc.p.coherence_other**2
        alpha = 1.0 + r0**3 / before.gm
        alpha2 = 1.0 + r0**3 / sc.gm
        with np.errstate(invalid="ignore"):
            b = r0**2 * r
            u, u2 = alpha * (1.0 + b / before.gm), alpha2 * (1.0 + b / sc.gm)
            t = np.where(np.isinf(b), alpha2 * before.gm / (alpha * sc.gm), (u2 - c2) / (u - c2))
        return np.where(u > c2, t, -np.inf)


def boxes(before: Problem, sc: Problem, leaves: np.ndarray, leaf_lb: np.ndarray, domain,
          shift: np.ndarray, restricted: bool) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(boxes, bounds) of the next search's first round (module docstring, Boxes) from the
    previous `leaves` (covering `domain`, (lo, hi) of (r0, angles), which holds sc's): moved
    by `shift` with the strips they leave, bounds None (all computed afresh), at most
    MOVED_MAX of them; else where the optimum stays, in place with their bounds carried, at
    most CARRIED_MAX. (None, None) past those sizes."""
    old_lo, old_hi = domain
    lo = np.array([sc.r0_lo] + [sc.th_lo] * len(sc.slaves))
    hi = np.array([sc.r0_hi] + [sc.th_hi] * len(sc.slaves))
    if _moves(leaves, leaf_lb, old_hi - old_lo, shift):
        if len(leaves) > MOVED_MAX:
            return None, None
        return _inside(leaves + np.repeat(shift, 2), lo, hi, old_lo + shift, old_hi + shift), None
    if len(leaves) > CARRIED_MAX:
        return None, None
    cut = leaves.copy()
    cut[:, 0::2] = np.maximum(cut[:, 0::2], lo)
    cut[:, 1::2] = np.minimum(cut[:, 1::2], hi)
    kept = np.all(cut[:, 0::2] <= cut[:, 1::2], axis=1)
    return cut[kept], carried(before, sc, leaves[kept], leaf_lb[kept], restricted)


def _moves(leaves: np.ndarray, leaf_lb: np.ndarray, widths: np.ndarray,
           shift: np.ndarray) -> bool:
    """Does the optimum move past the core's finest box in some coordinate (module
    docstring)? The core: boxes at most FINE times the finest (widths relative to the
    domain's) whose bounds are within NEAR of the least."""
    finite = np.isfinite(leaf_lb)
    if not finite.any():
        return False
    size = leaves[:, 1::2] - leaves[:, 0::2]
    rel = np.divide(size, widths, out=np.zeros_like(size), where=widths > 0).max(axis=1)
    core = finite & (rel <= FINE * rel[finite].min()) & (
        leaf_lb <= leaf_lb[finite].min() * (1.0 + NEAR))
    return bool(np.any(np.abs(shift) > size[core if core.any() else finite].min(axis=0)))


def _inside(moved: np.ndarray, lo: np.ndarray, hi: np.ndarray, a: np.ndarray,
            b: np.ndarray) -> np.ndarray:
    """The moved boxes cut to the domain [lo, hi] (without those that only touch it: a point
    of it on a box's face lies in another box that meets its inside too, unless the domain
    is flat there), and the domain's strips beyond prod_i [a_i, b_i], the moved boxes'."""
    cut = moved.copy()
    cut[:, 0::2] = np.maximum(cut[:, 0::2], lo)
    cut[:, 1::2] = np.minimum(cut[:, 1::2], hi)
    cut = cut[np.all((cut[:, 0::2] < cut[:, 1::2]) | ((cut[:, 0::2] == cut[:, 1::2]) & (lo == hi)),
                     axis=1)]
    strips = []
    for i in range(len(lo)):
        for beyond, ends in ((lo[i] < a[i], (lo[i], min(hi[i], a[i]))),
                             (hi[i] > b[i], (max(lo[i], b[i]), hi[i]))):
            if beyond:
                strip = np.stack([lo, hi], axis=1)
                strip[i] = ends
                strips.append(strip.ravel())
    return np.concatenate([cut, np.reshape(strips, (-1, cut.shape[1]))])
