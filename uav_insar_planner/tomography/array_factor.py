"""The elevation array factor of a SIMO swarm and its figures (TomoSAR), numpy only.

The master transmits and every UAV receives (single input, multiple output), so the N
receivers sample the elevation spectrum at their perpendicular baselines b_perp,k (b_perp,0 =
0 for the master). With the project's height-of-ambiguity convention (eq. 12,
model.height_of_ambiguity: h_amb,k = lambda r_0 sin(theta_0) / b_perp,k) a point at height h
has phase 2 pi h / h_amb,k = 2 pi kappa_k h in receiver k, kappa_k = b_perp,k / (lambda r_0
sin(theta_0)) [1/m] (`wavenumbers`), and the array factor is

    AF(h) = |(1/N) sum_k exp(j 2 pi kappa_k h)|

(arXiv 2605.27303, communication-assisted UAV-borne MIMO TomoSAR; Reigber and Moreira 2000;
Fornaro, Serafino and Soldovieri 2003). AF is even in h and AF(0) = 1. The figures
(`tomography_figures`), every one from AF alone:

- resolution rho = 1 / L = lambda r_0 sin(theta_0) / L_b, with L_b = max b_perp - min b_perp
  the span of the baselines (the Rayleigh limit);
- main lobe |h| <= h_1, h_1 the first local minimum of AF for h > 0;
- sidelobes: h_1 < |h| <= S, S the stated height span (`height_span_m`);
- PSLR = 20 log10(max sidelobe AF) (the maximum refined between samples, or AF(S));
- ISLR = 10 log10(int_side AF^2 / int_main AF^2), both integrals in closed form:
  int_{-a}^{a} AF^2 dh = (1/N^2) sum_{k,l} sin(2 pi a D_kl) / (pi D_kl), D_kl = kappa_k -
  kappa_l (2a when D_kl = 0) (`energy`), so ISLR's only approximation is h_1's refinement;
- the nearest ambiguity: the least h beyond the main lobe with AF(h) >= 0.9 (the first
  grating lobe; AF falls monotonically to h_1, so this is the least h > 0 with AF(h) >= 0.9
  once the main lobe's own neighbourhood of h = 0 is left), searched up to
  AMBIGUITY_HORIZON_CELLS resolutions (or S if farther), else None.

AF is sampled at SAMPLES_PER_CELL points per resolution, then every extremum is refined by
golden-section search and the 0.9 crossing by bisection, to well under 0.1 % of a resolution.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

AMBIGUITY_LEVEL = 0.9
AMBIGUITY_HORIZON_CELLS = 256
SAMPLES_PER_CELL = 64
REFINE_STEPS = 40  # golden section: 0.618^40 of a 1/32-resolution bracket, ~1e-10 resolutions
CHUNK = 1 << 15  # heights per block when sampling AF (memory stays at a few MB)
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0


def array_factor(kappa: np.ndarray, h: np.ndarray | float) -> np.ndarray:
    """AF(h) = |(1/N) sum_k exp(j 2 pi kappa_k h)| at heights h [m] (any shape), kappa [1/m]."""
    kappa = np.asarray(kappa, dtype=float)
    h = np.asarray(h, dtype=float)
    phase = 2.0 * np.pi * h[..., None] * kappa
    return np.hypot(np.cos(phase).mean(axis=-1), np.sin(phase).mean(axis=-1))


def scalar_af(kappa: np.ndarray):
    """AF as a function of one height (plain floats: the refinements' many calls are fast)."""
    ks = [2.0 * math.pi * float(k) for k in kappa]
    n = len(ks)

    def af(h: float) -> float:
        return math.hypot(sum(math.cos(k * h) for k in ks), sum(math.sin(k * h) for k in ks)) / n

    return af


def energy(kappa: np.ndarray, a: float) -> float:
    """int_{-a}^{a} AF(h)^2 dh in closed form (module docstring), a >= 0 [m]."""
    kappa = np.asarray(kappa, dtype=float)
    d = kappa[:, None] - kappa[None, :]
    return float(np.sum(2.0 * a * np.sinc(2.0 * a * d)) / kappa.size**2)


def golden(f, lo: float, hi: float, maximise: bool = False) -> float:
    """The extremum of a unimodal f on [lo, hi] by golden-section search (REFINE_STEPS)."""
    sign = -1.0 if maximise else 1.0
    a, b = lo, hi
    c, d = b - _GOLD * (b - a), a + _GOLD * (b - a)
    fc, fd = sign * f(c), sign * f(d)
    for _ in range(REFINE_STEPS):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - _GOLD * (b - a)
            fc = sign * f(c)
        else:
            a, c, fc = c, d, fd
            d = a + _GOLD * (b - a)
            fd = sign * f(d)
    return 0.5 * (a + b)


@dataclass(frozen=True)
class TomographyFigures:
    """The figures of one array (module docstring), SI; dB only in pslr_db and islr_db."""

    resolution_m: float
    main_lobe_m: float           # h_1, the first minimum
    ambiguity_height_m: float | None
    ambiguity_search_m: float    # how far the ambiguity was searched
    pslr_db: float | None        # None when no sidelobe lies within the span
    islr_db: float | None
    peak_sidelobe_height_m: float | None
    height_span_m: float

    def to_dict(self) -> dict[str, float | None]:
        return {k: None if v is None else float(v) for k, v in self.__dict__.items()}


def _samples(kappa: np.ndarray, top: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    h = np.arange(0.0, top + step, step)
    af = np.concatenate([array_factor(kappa, h[i:i + CHUNK]) for i in range(0, h.size, CHUNK)])
    return h, af


def first_minimum(kappa: np.ndarray, h: np.ndarray, af: np.ndarray) -> float | None:
    """h_1, the first local minimum of AF for h > 0 on the samples, refined; None if none."""
    inner = np.flatnonzero((af[1:-1] <= af[:-2]) & (af[1:-1] < af[2:])) + 1
    if not inner.size:
        return None
    i = int(inner[0])
    return golden(scalar_af(kappa), h[i - 1], h[i + 1])


def _maxima(h: np.ndarray, af: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Indices of the samples' local maxima within (lo, hi)."""
    idx = np.flatnonzero((af[1:-1] >= af[:-2]) & (af[1:-1] > af[2:])) + 1
    return idx[(h[idx] > lo) & (h[idx] < hi)]


def _refined(kappa: np.ndarray, h: np.ndarray, i: int, lo: float, hi: float
             ) -> tuple[float, float]:
    """(height, AF) of the local maximum at sample i, refined within [lo, hi]."""
    af = scalar_af(kappa)
    x = golden(af, max(h[i - 1], lo), min(h[i + 1], hi), maximise=True)
    return x, af(x)


def _crossing(kappa: np.ndarray, lo: float, hi: float) -> float:
    """The h in [lo, hi] where AF rises through AMBIGUITY_LEVEL (AF(lo) < level <= AF(hi))."""
    af = scalar_af(kappa)
    for _ in range(REFINE_STEPS):
        mid = 0.5 * (lo + hi)
        if af(mid) >= AMBIGUITY_LEVEL:
            hi = mid
        else:
            lo = mid
    return hi


def tomography_figures(kappa: np.ndarray, height_span_m: float) -> TomographyFigures:
    """The figures of the array with wavenumbers `kappa` [1/m] over |h| <= height_span_m.

    Raises ValueError when every kappa is equal (no elevation aperture: resolution infinite).
    """
    kappa = np.asarray(kappa, dtype=float)
    span_k = float(kappa.max() - kappa.min())
    if not span_k > 0.0:
        raise ValueError("tomography: every receiver has the same b_perp; no elevation aperture")
    rho = 1.0 / span_k
    horizon = max(height_span_m, AMBIGUITY_HORIZON_CELLS * rho)
    h, af = _samples(kappa, horizon, rho / SAMPLES_PER_CELL)
    h1 = first_minimum(kappa, h, af)
    h1 = horizon if h1 is None else h1
    ambiguity = None
    near = 0.8 * AMBIGUITY_LEVEL  # a sampled peak is within 0.1 % of the refined one
    for i in (j for j in _maxima(h, af, h1, horizon) if af[j] >= near):
        x, value = _refined(kappa, h, int(i), h1, horizon)
        if value >= AMBIGUITY_LEVEL:
            below = h[(h < x) & (h >= h1) & (af < AMBIGUITY_LEVEL)]
            ambiguity = _crossing(kappa, float(below.max()) if below.size else h1, x)
            break
    side = [_refined(kappa, h, int(i), h1, height_span_m)
            for i in _maxima(h, af, h1, height_span_m)]
    if h1 < height_span_m:
        side.append((height_span_m, scalar_af(kappa)(height_span_m)))
    if not side:
        return TomographyFigures(rho, h1, ambiguity, horizon, None, None, None, height_span_m)
    x_peak, peak = max(side, key=lambda s: s[1])
    main = energy(kappa, h1)
    islr = 10.0 * math.log10(max(energy(kappa, height_span_m) - main, 1e-300) / main)
    return TomographyFigures(rho, h1, ambiguity, horizon, 20.0 * math.log10(max(peak, 1e-300)),
                             islr, x_peak, height_span_m)
