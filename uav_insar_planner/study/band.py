"""The spread of the true sigma_h over the minimisers of Proposition 1's bound.

The paper minimises the bound; when its minimum is reached by a whole set of formations (every
C8 tight), sigma_h differs across that set. `bound_minimizer_band` reports its range, which the
sweeps draw as a band (see its docstring).
"""
from __future__ import annotations

import math
from itertools import combinations

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import Params
from uav_insar_planner.solver import rays
from uav_insar_planner.solver.global_opt.optimum import solve_global
from uav_insar_planner.solver.problem import Problem, make_problem
from uav_insar_planner.solver.result import SolverResult


def bound_minimizer_band(p: Params, scheme: str, samples: int = 160) -> tuple[float, float]:
    """(lo, hi): the least and largest true sigma_h over the formations minimising Proposition
    1's bound.

    The bound is C r0 / sqrt(sum_k b_perp,k^2) and C8 caps each b_perp,k at
    lambda r0 sin(theta_0) / h_amb,k^min (slave k's rung), so it is at least the r0-free value
    C / (lambda sin(theta_0) sqrt(sum_k h_amb,k^min^-2)), reached exactly by the feasible
    formations with every C8 tight. When the bound's global minimum equals that value (Table I
    and the figure sweeps), the minimisers are that whole set: each slave on the curve
    r_k = b_max(r0) / |sin(theta_k - theta_0)|, any r0 and angles keeping C1-C11. The band is
    sampled: on a (r0, theta_1, theta_2) grid for up to two slaves; for more, where a grid over
    K angles is too large, at `samples`^2 * 8 seeded random points of (r0, theta_1..K), an
    inner estimate that always holds the solver's minimiser. When the bound's minimum is not
    that value, the global solver's minimiser is reported as a zero-width band. (nan, nan) if
    infeasible.
    """
    res = solve_global(p, scheme, "bound")
    if not res.feasible:
        return math.nan, math.nan
    sc = make_problem(p, scheme, "exact")
    n = len(sc.slaves)
    sigma_phi_a = sc.sigma_phi_bound
    # sum_k b_perp,k^2 <= (lambda r0 sin(theta_0))^2 sum_k h_amb,k^min^-2 (per-slave rungs)
    c8_value = sigma_phi_a / (2.0 * math.pi * math.sqrt(sum(model.h_amb_min_of(p, k) ** -2
                                                            for k in sc.slaves)))
    bound_value = _objective(p, res, scheme)
    if not (sc.on("C8") and bound_value <= c8_value * (1.0 + 1e-6)):
        s = _exact_sigma(p, res, scheme)
        return s, s
    if n > 2:  # the solver's minimiser is in the set too, whatever the draws miss
        s = _exact_sigma(p, res, scheme)
        lo, hi = _band_sampled(sc, samples * samples * 8)
        return (s, s) if math.isnan(lo) else (min(lo, s), max(hi, s))
    r0s = (np.array([sc.r0_lo]) if sc.r0_lo == sc.r0_hi
           else np.linspace(sc.r0_lo, sc.r0_hi, samples // 2))
    th = np.linspace(sc.th_lo, sc.th_hi, samples)
    lo, hi = _band_on_grid(sc, r0s, th)
    return lo, hi


def _objective(p: Params, res: SolverResult, scheme: str) -> float:
    return evaluate(p, res.formation, res.p_com, scheme).sigma_h_bound


def _exact_sigma(p: Params, res: SolverResult, scheme: str) -> float:
    return evaluate(p, res.formation, res.p_com, scheme).sigma_h


def _c8_tight_sigma(sc: Problem, k: int, r0, th):
    """Per slave on its C8-tight curve: (feasible mask, range, 1/sigma_h,k^2)."""
    b = rays.baseline_limit(sc, r0, k)
    with np.errstate(divide="ignore"):
        r = b / np.abs(np.sin(th - sc.th0))
    lo, up = rays.ray_limits(sc, k, r0, th)
    h1, h2 = rays.master_hole(sc, r0, th)
    ok = (r >= lo) & (r <= up * (1 + 1e-12)) & ~((r > h1) & (r < h2)) & np.isfinite(r)
    w = rays.weight(sc, b, rays.coherence_rg(sc, th), rays.snr_factor(sc, r0, r))
    return ok, r, w


def _band_on_grid(sc: Problem, r0s, th):
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



def _band_sampled(sc: Problem, draws: int, seed: int = 0,
                  chunk: int = 50_000) -> tuple[float, float]:
    """The band's range over `draws` uniform random (r0, theta_1..K), each slave on its
    C8-tight curve; C4 between every two slaves (the master's disk is in each slave's
    ray). Seeded, so a sweep's band is the same run after run."""
    rng = np.random.default_rng(seed)
    lo, hi = math.inf, -math.inf
    for start in range(0, draws, chunk):
        m = min(chunk, draws - start)
        r0 = rng.uniform(sc.r0_lo, sc.r0_hi, m)
        ok, w, at = np.ones(m, bool), np.zeros(m), []
        for k in sc.slaves:
            th = rng.uniform(sc.th_lo, sc.th_hi, m)
            ok_k, r_k, w_k = _c8_tight_sigma(sc, k, r0, th)
            ok &= ok_k
            w += np.where(ok_k, w_k, 0.0)
            at.append((r_k, th))
        if sc.on("C4"):
            for (ri, ti), (rj, tj) in combinations(at, 2):
                with np.errstate(invalid="ignore"):
                    ok &= ri * ri + rj * rj - 2 * np.cos(ti - tj) * ri * rj >= sc.p.d_min**2
        if ok.any():
            s = rays.objective_from_weights(sc, r0[ok], w[ok])
            lo, hi = min(lo, float(s.min())), max(hi, float(s.max()))
    return (lo, hi) if math.isfinite(lo) else (math.nan, math.nan)
