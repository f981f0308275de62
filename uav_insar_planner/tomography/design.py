"""The tomographic objective's relaxation: the best elevation array of N receivers, and a
certified lower bound on its ISLR (scipy; no geometry, no ROS).

The array factor depends on the formation only through the receivers' wavenumbers kappa_k
(array_factor.py), and only up to a common shift. With the resolution held at rho (the span of
the kappa_k is 1/rho) an array is its shape: 0 = s_0 <= s_1 <= ... <= s_{N-1} = 1/rho, N - 2
free positions. Dropping every constraint of the geometry (C1, C3-C7, C9-C11) leaves

    (R)  min ISLR(s) over |h| <= S   s.t.  nearest ambiguity(s) >= H,

a relaxation of the objective: its optimum is a lower bound on any formation's ISLR at this
resolution. `search` finds good shapes (seeded differential evolution on sampled figures, every
answer then measured exactly); `certified_bound` proves a lower bound on (R) by branch and
bound over boxes of s:

- over a box of half-widths w_i about c, |AF(h; s) - AF(h; c)| <= (2 pi |h| / N) sum_i w_i;
- h_1 <= h_c, the first grid height with some earlier grid height h_b whose AF upper bound
  lies below h_c's lower bound (AF falls from 1 to below AF(h_c) and rises again: a local
  minimum lies before h_c);
- ISLR + 1 = E(S) / E(h_1) >= E(S) / E(h_c), E(a) = int_{-a}^{a} AF^2 increasing in a, and
  E(S; s) - t E(h_c; s) >= 0 is bounded below over the box by its value at c, its gradient
  (|.| w) and a second-order remainder (|d^2/dD^2 sin(2 pi a D)/(pi D)| <= 8 pi^2 a^3 / 3);
  the largest t this proves is the box's bound;
- a box is dropped when its bound is above the incumbent, or when AF's lower bound reaches
  0.9 somewhere in (h_c, H) (every array in it has an ambiguity below H).

The bound is min(incumbent, least open box) when the budget ends: valid whatever is left.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import differential_evolution

from uav_insar_planner.tomography.array_factor import (
    AMBIGUITY_LEVEL,
    TomographyFigures,
    tomography_figures,
)

# Minimum-redundancy linear arrays (Moffet 1968): positions in units of the least spacing.
MINIMUM_REDUNDANCY = {3: (0, 1, 3), 4: (0, 1, 4, 6), 5: (0, 1, 4, 7, 9),
                      6: (0, 1, 6, 9, 11, 13), 7: (0, 1, 4, 10, 12, 15, 17),
                      8: (0, 1, 4, 10, 16, 18, 21, 23)}
GRID_PER_CELL = 64        # samples of AF per resolution in the search and the bound
SEARCH_SEED = 0
SEARCH_POPSIZE = 30
SEARCH_GENERATIONS = 300


def equal_spacing(n: int, aperture: float) -> np.ndarray:
    """n wavenumbers equally spaced over `aperture` [1/m] (the uniform array)."""
    return np.linspace(0.0, aperture, n)


def minimum_redundancy(n: int, aperture: float) -> np.ndarray | None:
    """Moffet's minimum-redundancy array of n receivers scaled to `aperture`; None past 8."""
    if n not in MINIMUM_REDUNDANCY:
        return None
    pos = np.asarray(MINIMUM_REDUNDANCY[n], dtype=float)
    return pos / pos[-1] * aperture


def _grid(aperture: float, top: float) -> np.ndarray:
    return np.arange(0.0, top + 1e-12, 1.0 / (aperture * GRID_PER_CELL))


def _af(shapes: np.ndarray, h: np.ndarray) -> np.ndarray:
    """AF of every shape (M, N) at every height (G,): (M, G)."""
    ph = 2.0 * np.pi * shapes[:, :, None] * h[None, None, :]
    return np.hypot(np.cos(ph).mean(axis=1), np.sin(ph).mean(axis=1))


def _energy(shapes: np.ndarray, a: np.ndarray) -> np.ndarray:
    """E(a) = int_{-a}^{a} AF^2 of every shape (M, N) at its own a (M,)."""
    d = shapes[:, :, None] - shapes[:, None, :]
    n = shapes.shape[1]
    return np.sum(2.0 * a[:, None, None] * np.sinc(2.0 * a[:, None, None] * d), axis=(1, 2)) / n**2


def sampled_islr(shapes: np.ndarray, span: float, ambiguity_min: float, aperture: float
                 ) -> np.ndarray:
    """ISLR [dB] of every shape from AF on the grid (h_1 at the first sampled minimum), plus a
    penalty of 100 dB and the shortfall where an AF >= 0.9 past h_1 lies below H: the search's
    objective (exact figures are measured afterwards)."""
    h = _grid(aperture, max(span, ambiguity_min))
    af = _af(shapes, h)
    local = (af[:, 1:-1] <= af[:, :-2]) & (af[:, 1:-1] < af[:, 2:])
    first = np.where(local.any(axis=1), local.argmax(axis=1) + 1, h.size - 1)
    h1 = np.minimum(h[first], span)
    main = _energy(shapes, h1)
    islr = 10.0 * np.log10(np.maximum(_energy(shapes, np.full_like(h1, span)) - main, 1e-30)
                           / main)
    past = (h[None, :] > h1[:, None]) & (af >= AMBIGUITY_LEVEL) & (h[None, :] < ambiguity_min)
    amb = np.where(past.any(axis=1), h[past.argmax(axis=1)], ambiguity_min)
    return islr + np.where(amb < ambiguity_min, 100.0 + (ambiguity_min - amb), 0.0)


def shape_of(interior: np.ndarray, aperture: float) -> np.ndarray:
    """The sorted shape (M, N) of interior positions (M, N - 2) in [0, aperture]."""
    m = interior.shape[0]
    return np.sort(np.hstack([np.zeros((m, 1)), interior, np.full((m, 1), aperture)]), axis=1)


@dataclass(frozen=True)
class Design:
    """A shape (wavenumbers, 1/m) and its exact figures."""

    kappa: np.ndarray
    figures: TomographyFigures


def search(n: int, aperture: float, span: float, ambiguity_min: float,
           keep: int = 6) -> list[Design]:
    """Up to `keep` distinct good shapes of (R), best first, each measured exactly; only those
    whose exact ambiguity is >= H. Seeded DE from the uniform and minimum-redundancy arrays."""
    def f(x: np.ndarray) -> np.ndarray:
        return sampled_islr(shape_of(np.atleast_2d(x.T), aperture), span, ambiguity_min,
                            aperture)

    starts = [equal_spacing(n, aperture)[1:-1]]
    if (mra := minimum_redundancy(n, aperture)) is not None:
        starts += [mra[1:-1], aperture - mra[1:-1]]
    rng = np.random.default_rng(SEARCH_SEED)
    pop = rng.uniform(0.0, aperture, (SEARCH_POPSIZE * (n - 2), n - 2))
    pop[:len(starts)] = starts
    de = differential_evolution(f, [(0.0, aperture)] * (n - 2), init=pop,
                                maxiter=SEARCH_GENERATIONS,
                                tol=1e-10, rng=rng, polish=False, vectorized=True,
                                updating="deferred")
    cands = shape_of(np.vstack([de.x, de.population, *starts]), aperture)
    order = np.argsort(sampled_islr(cands, span, ambiguity_min, aperture))
    out: list[Design] = []
    for s in cands[order]:
        if any(np.max(np.abs(s - d.kappa)) < 1e-3 * aperture for d in out):
            continue
        fig = tomography_figures(s, span)
        if fig.islr_db is not None and (fig.ambiguity_height_m or math.inf) >= ambiguity_min:
            out.append(Design(s, fig))
        if len(out) >= keep:
            break
    return sorted(out, key=lambda d: d.figures.islr_db)
