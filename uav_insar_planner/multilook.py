"""The exact multilook interferometric phase statistics (Lee et al. 1994; Touzi and Lopes 1996).

For n_L independent looks of a pixel pair with coherence gamma (true phase 0), the phase psi of
sum_l z1_l z2_l^* has the density, with beta = gamma cos(psi),

    p(psi) = Gamma(n_L + 1/2) (1 - gamma^2)^n_L beta
             / (2 sqrt(pi) Gamma(n_L) (1 - beta^2)^(n_L + 1/2))
             + (1 - gamma^2)^n_L / (2 pi) 2F1(n_L, 1; 1/2; beta^2).

With F(a) = 2F1(a, 1; 1/2; z) and H(a) = (1 - z)^a F(a), Gauss's contiguous relation in a gives
the forward recursion (stable: H is the dominant solution, growing like sqrt(a))

    H(a + 1) = [(2a - 1/2 + (1 - a) z) H(a) - (a - 1/2)(1 - z) H(a - 1)] / a,
    H(0) = 1, H(1) = 1 + sqrt(z) arcsin(sqrt(z)) / sqrt(1 - z),

so p = q^n_L [Gamma(n_L + 1/2) / (2 sqrt(pi) Gamma(n_L)) beta / sqrt(1 - beta^2) + H(n_L) / (2 pi)]
with q = (1 - gamma^2) / (1 - beta^2) <= 1: no overflow for any n_L.

The standard deviation sigma(gamma, n_L) = sqrt(integral psi^2 p dpsi over (-pi, pi]) is
integrated with composite Gauss-Legendre panels graded towards psi = 0 (`phase_std_exact`). The
planner's objective uses `phase_std`, a table per n_L (computed once, cached in the process) of
log sigma against v = log((1 - gamma^2) / (n_L gamma^2)) = 2 log sigma_CR + log 2, linearly
interpolated. Accuracy (test/test_multilook.py): the integral matches the single-look closed
form to 1e-9 and has unit mass to 1e-9 (n_L <= 1000); the table matches the integral to 1e-6
relative between its nodes (`TABLE_REL_ERROR`). A table costs 0.1 s for n_L = 4, 4.4 s for 1000.

Monotonicity, which the certified solver's bounds need (solver/global_opt/slave_ranges.py):
sigma decreases in gamma (d log sigma / dv > 0), and d log sigma / dv < 1, which makes a
slave's weight b_perp^2 / sigma^2 increase with its range as for the Cramer-Rao figure (whose
slope is exactly 1/2). Both are checked on every table when it is built (`_table`).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.special import gammaln

from uav_insar_planner import model
from uav_insar_planner.params import MULTILOOK_MAX_LOOKS

MAX_LOOKS = MULTILOOK_MAX_LOOKS   # the O(n_L) recursion: 4.4 s per table at 1000 looks
TABLE_REL_ERROR = 1e-6
UNIFORM_STD = math.pi / math.sqrt(3.0)   # gamma = 0: psi uniform on (-pi, pi]
_V_LO, _V_HI, _V_STEP = -16.0, 14.0, 0.005
_GL_X, _GL_W = np.polynomial.legendre.leggauss(12)
_PANELS = 16


def phase_pdf(psi, gamma, looks: int) -> np.ndarray:
    """p(psi; gamma, n_L) of the multilook phase (module docstring); broadcasts."""
    if looks < 1:
        raise ValueError(f"looks: value {looks!r} is not allowed; expected an integer >= 1")
    g = np.asarray(gamma, dtype=float)
    beta = g * np.cos(np.asarray(psi, dtype=float))
    z = beta * beta
    one_z = np.maximum(1.0 - z, 1e-300)
    h_prev, h = np.ones_like(z), 1.0 + np.sqrt(z) * np.arcsin(np.sqrt(z)) / np.sqrt(one_z)
    for a in range(1, looks):
        h_prev, h = h, ((2.0 * a - 0.5 + (1.0 - a) * z) * h - (a - 0.5) * one_z * h_prev) / a
    q_pow = np.exp(looks * (np.log1p(-np.minimum(g * g, 1.0 - 1e-16)) - np.log(one_z)))
    c = math.exp(gammaln(looks + 0.5) - gammaln(looks)) / (2.0 * math.sqrt(math.pi))
    return q_pow * (c * beta / np.sqrt(one_z) + h / (2.0 * math.pi))


def _nodes(gamma: np.ndarray, looks: int):
    """Gauss-Legendre nodes and weights on [0, pi] per gamma (rows), panels geometrically
    graded from a width well below the Cramer-Rao std up to pi."""
    crb = np.asarray(model.phase_error_crb(np.maximum(gamma, 1e-12), looks))
    first = np.clip(crb / 8.0, 1e-9, math.pi / _PANELS)
    ratio = (math.pi / first) ** (1.0 / (_PANELS - 1))
    edges = first[:, None] * ratio[:, None] ** np.arange(_PANELS)[None, :]
    edges = np.concatenate([np.zeros((len(gamma), 1)), edges], axis=1)
    edges[:, -1] = math.pi
    a, b = edges[:, :-1, None], edges[:, 1:, None]
    x = 0.5 * (b - a) * _GL_X + 0.5 * (a + b)
    w = 0.5 * (b - a) * _GL_W
    return x.reshape(len(gamma), -1), w.reshape(len(gamma), -1)


def phase_moments(gamma, looks: int) -> tuple[np.ndarray, np.ndarray]:
    """(integral of p, integral of psi^2 p) over (-pi, pi] per gamma; the first should be 1
    and is the quadrature's own accuracy check."""
    g = np.atleast_1d(np.asarray(gamma, dtype=float))
    x, w = _nodes(g, looks)
    p = phase_pdf(x, g[:, None], looks)
    return 2.0 * np.sum(w * p, axis=1), 2.0 * np.sum(w * p * x * x, axis=1)


def phase_std_exact(gamma, looks: int) -> np.ndarray:
    """sigma(gamma, n_L) of the multilook phase by numerical integration (no table)."""
    g = np.atleast_1d(np.asarray(gamma, dtype=float))
    out = np.empty_like(g)
    for i in range(0, len(g), 512):  # bounded memory: 512 x 192 nodes at a time
        mass, second = phase_moments(g[i:i + 512], looks)
        out[i:i + 512] = np.sqrt(second / mass)
    return out.reshape(np.shape(gamma))


def _v_of_gamma(g, looks: int):
    g = np.asarray(g, dtype=float)
    with np.errstate(divide="ignore"):
        return np.log1p(-g * g) - np.log(looks * g * g)


@lru_cache(maxsize=16)
def _table(looks: int) -> tuple[np.ndarray, np.ndarray]:
    """(v grid, log sigma on it) for n_L looks, checked monotone with slope in (0, 1)."""
    if not 1 <= looks <= MAX_LOOKS:
        raise ValueError(f"looks: value {looks!r} is not allowed for objective multilook; "
                         f"expected an integer in [1, {MAX_LOOKS}]")
    v = np.arange(_V_LO, _V_HI + 0.5 * _V_STEP, _V_STEP)
    # gamma from v: (1 - g^2)/(n g^2) = e^v  ->  g^2 = 1 / (1 + n e^v)
    g = 1.0 / np.sqrt(1.0 + looks * np.exp(v))
    log_s = np.log(phase_std_exact(g, looks))
    slope = np.diff(log_s) / _V_STEP
    if not (np.all(slope > 0.0) and np.all(slope < 1.0)):
        raise ArithmeticError(f"multilook table for n_L={looks} is not monotone with slope "
                              f"in (0, 1): {slope.min():.3g}..{slope.max():.3g}")
    return v, log_s


def phase_std(gamma, looks: int) -> np.ndarray:
    """sigma(gamma, n_L) from the cached table (module docstring): strictly decreasing in
    gamma; beyond the table, Cramer-Rao scaled to the table's end (high coherence) and a
    straight line to pi/sqrt(3) at gamma = 0 (low coherence). gamma = 1 gives 0."""
    v_grid, log_s = _table(looks)
    g = np.clip(np.asarray(gamma, dtype=float), 0.0, 1.0)
    v = _v_of_gamma(g, looks)
    inside = np.exp(np.interp(v, v_grid, log_s))
    with np.errstate(invalid="ignore", divide="ignore"):
        high = np.exp(log_s[0] + 0.5 * (v - v_grid[0]))
        g_end = 1.0 / math.sqrt(1.0 + looks * math.exp(v_grid[-1]))
        s_end = math.exp(log_s[-1])
        low = UNIFORM_STD - (UNIFORM_STD - s_end) * g / g_end
    out = np.where(v < v_grid[0], high, np.where(v > v_grid[-1], low, inside))
    return np.where(g >= 1.0, 0.0, out)


def plan_metrics(pairs: dict[str, dict[str, float]], looks: int) -> dict[str, object]:
    """The multilook figures of a checked plan, from the checker's per-pair coherence and h_amb:
    per pair sigma_Phi (exact) and sigma_hk (eq. 13), fused with eq. 15's weights."""
    out: dict[str, object] = {"pairs": {}}
    sig = []
    for name, pm in pairs.items():
        s_phi = float(phase_std(pm["coherence_total"], looks))
        s_h = float(model.height_error(pm["h_amb_m"], s_phi))
        out["pairs"][name] = {"phase_error_rad": s_phi, "sigma_h_m": s_h}
        sig.append(s_h)
    out["sigma_h_m"] = float(model.fused_height_error(*sig))
    return out
