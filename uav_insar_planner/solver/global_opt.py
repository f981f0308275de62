"""Certified global solver of problem (P) for the four schemes and both objectives.

`solve_global` reduces (P) to the master range r0 and the slave look angles (rays.py: C2, and
every other constraint an interval of slave ranges along each look-angle ray; pairs.py: the
slaves sit at the top of their feasible ranges, or one steps down to keep C4 between them) and
runs the branch and bound of certificate.py, whose smallest open or closed box bound is a proven
lower bound on the objective over the feasible set. An empty search (every box proven empty)
proves infeasibility; the blocking constraint families are then an irreducible infeasible set
and the message adds the smallest sets whose removal alone makes it feasible (blocking.py).

`bound_minimizer_band` gives the spread of the true sigma_h over the minimisers of
Proposition 1's bound, the paper's solution set (see its docstring).
"""
from __future__ import annotations

import math

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.solver import blocking, certificate, power, rays
from uav_insar_planner.solver.result import SolverResult

# Branch and bound closes a box when its bound is within REL_GAP of the incumbent, so the
# reported relative gap is at most REL_GAP (the target is 1e-4).
REL_GAP = 5e-5


def _nan_result(p: Params, nodes: int, **kw) -> SolverResult:
    return SolverResult(feasible=False, formation=np.full((3, 2), np.nan),
                        p_com=np.zeros((3, p.num_slots)), iterations=nodes, **kw)


def master_on_c2(p: Params) -> bool:
    """Fixed-master scheme: does q0_fixed satisfy C2 (to the checker's tolerance)?"""
    x0, z0 = p.master_fixed
    return abs(x0 - float(model.master_x(z0, p.x_t, p.theta0))) <= 1e-6


def formation_of(sc: rays.Scenario, point) -> np.ndarray:
    """(3, 2) formation from (r0, theta1, theta2, r1, r2); NaN row for a UAV not flown."""
    r0, t1, t2, r1, r2 = point
    q = np.full((3, 2), np.nan)
    if sc.scheme == "fixed-master":
        q[0] = sc.p.master_fixed
    else:
        q[0] = rays.position(sc, r0, sc.th0)
    q[1] = rays.position(sc, r1, t1)
    if len(sc.slaves) == 2:
        q[2] = rays.position(sc, r2, t2)
    return q


def solve_global(p: Params, scheme: str, objective: str) -> SolverResult:
    """Global minimum of sigma_h (`exact`, eq. 15) or of Proposition 1's bound (`bound`) over
    C1..C11 for `scheme`, with a certificate: lower_bound <= optimum <= objective."""
    if scheme == "fixed-master" and not master_on_c2(p):
        return _nan_result(p, 0, blocking=["C2"], lower_bound=math.inf,
                           certificate="q0_fixed violates C2", message="q0_fixed is off the "
                           "master's look-angle line x0 = x_t - z0 tan(theta_0)")
    sc = rays.make_scenario(p, scheme, objective)
    res = certificate.search(sc, rel_gap=REL_GAP)
    if res.point is None:
        block = blocking.irreducible_set(p, scheme)
        _, fixes = blocking.blocking_sets(p, scheme)
        relax = ("; relaxing any of these alone makes it feasible: "
                 + ", ".join("+".join(s) for s in fixes)) if fixes else ""
        together = " + ".join(block) + (" cannot hold together" if len(block) > 1
                                        else " cannot be met") + relax
        if not res.exhausted:
            return _nan_result(p, res.nodes, blocking=block, lower_bound=res.lower_bound,
                               message="no feasible point found and infeasibility not proven "
                               f"within {res.nodes} boxes; " + together)
        return _nan_result(p, res.nodes, blocking=block, lower_bound=math.inf,
                           certificate="infeasible: every box of (r0, theta1, theta2) proven "
                           "empty by interval bounds of the C1-C11 range limits",
                           message=together)
    # The search's incumbent is a box centre within REL_GAP of the optimum; a local compass
    # search takes it to the optimum to machine-level accuracy (value <= the incumbent's).
    widths = (sc.r0_hi - sc.r0_lo, sc.th_hi - sc.th_lo, sc.th_hi - sc.th_lo)
    value, point = certificate.polish(sc, res.point, [1e-3 * w for w in widths])
    lower = min(res.lower_bound, value)
    q = formation_of(sc, point)
    gap = (value - lower) / value
    dims = "r0, theta1, theta2" if len(sc.slaves) == 2 else "r0, theta1"
    return SolverResult(
        feasible=True, formation=q, p_com=power.schedules(p, q, scheme), iterations=res.nodes,
        lower_bound=lower, gap=gap,
        certificate=(f"branch and bound over ({dims}) boxes with monotone interval bounds; "
                     f"{res.nodes} boxes, " + ("all closed" if res.exhausted
                                               else "node limit reached")),
        message="" if res.exhausted else "certificate incomplete: node limit reached")


def bound_minimizer_band(p: Params, scheme: str, samples: int = 160) -> tuple[float, float]:
    """(lo, hi): the least and largest true sigma_h over the formations minimising Proposition
    1's bound.

    The bound is C r0 / sqrt(sum_k b_perp,k^2) and C8 caps each b_perp,k at
    lambda r0 sin(theta_0) / h_amb^min, so it is at least the r0-free value
    C h_amb^min / (lambda sin(theta_0) sqrt(n_slaves)), reached exactly by the feasible
    formations with every C8 tight. When the bound's global minimum equals that value (Table I
    and the figure sweeps), the minimisers are that whole set: each slave on the curve
    r_k = b_max(r0) / |sin(theta_k - theta_0)|, any r0 and angles keeping C1-C11. The band is
    sampled on a (r0, theta_1, theta_2) grid and polished; otherwise the minimiser found by
    the global solver is reported as a zero-width band. (nan, nan) if infeasible.
    """
    res = solve_global(p, scheme, "bound")
    if not res.feasible:
        return math.nan, math.nan
    sc = rays.make_scenario(p, scheme, "exact")
    n = len(sc.slaves)
    sigma_phi_a = sc.sigma_phi_bound
    c8_value = p.h_amb_min * sigma_phi_a / (2.0 * math.pi * math.sqrt(n))
    bound_value = _objective(p, res, scheme)
    if not (sc.on("C8") and bound_value <= c8_value * (1.0 + 1e-6)):
        s = _exact_sigma(p, res, scheme)
        return s, s
    r0s = (np.array([sc.r0_lo]) if sc.r0_lo == sc.r0_hi
           else np.linspace(sc.r0_lo, sc.r0_hi, samples // 2))
    th = np.linspace(sc.th_lo, sc.th_hi, samples)
    lo, hi = _band_on_grid(sc, r0s, th)
    return lo, hi


def _objective(p: Params, res: SolverResult, scheme: str) -> float:
    from uav_insar_planner.evaluate import evaluate

    return evaluate(p, res.formation, res.p_com, scheme).sigma_h_bound


def _exact_sigma(p: Params, res: SolverResult, scheme: str) -> float:
    from uav_insar_planner.evaluate import evaluate

    return evaluate(p, res.formation, res.p_com, scheme).sigma_h


def _c8_tight_sigma(sc: rays.Scenario, k: int, r0, th):
    """Per slave on its C8-tight curve: (feasible mask, range, 1/sigma_h,k^2)."""
    b = rays.baseline_limit(sc, r0)
    with np.errstate(divide="ignore"):
        r = b / np.abs(np.sin(th - sc.th0))
    lo, up = rays.ray_limits(sc, k, r0, th)
    h1, h2 = rays.master_hole(sc, r0, th)
    ok = (r >= lo) & (r <= up * (1 + 1e-12)) & ~((r > h1) & (r < h2)) & np.isfinite(r)
    w = rays.weight(sc, b, rays.coherence_rg(sc, th), rays.snr_factor(sc, r0, r))
    return ok, r, w


def _band_on_grid(sc: rays.Scenario, r0s, th):
    r0 = r0s[:, None]
    ok1, ra, w1 = _c8_tight_sigma(sc, 1, r0, th[None, :])
    if len(sc.slaves) == 1:
        s = np.where(ok1, rays.objective_from_weights(sc, r0, w1), np.nan)
        return float(np.nanmin(s)), float(np.nanmax(s))
    ok2, rb, w2 = _c8_tight_sigma(sc, 2, r0, th[None, :])
    r0 = r0s[:, None, None]
    c = np.cos(th[:, None] - th[None, :])[None]
    r1, r2 = ra[:, :, None], rb[:, None, :]
    sep = r1 * r1 + r2 * r2 - 2 * c * r1 * r2 >= sc.p.d_min**2 if sc.on("C4") else True
    ok = ok1[:, :, None] & ok2[:, None, :] & sep
    with np.errstate(invalid="ignore"):
        s = np.where(ok, rays.objective_from_weights(sc, r0, w1[:, :, None] + w2[:, None, :]),
                     np.nan)
    if not np.isfinite(s).any():
        return math.nan, math.nan
    return float(np.nanmin(s)), float(np.nanmax(s))

