"""The certified lower bound on the relaxation (R) of the tomographic objective: branch and
bound over boxes of the shape's N - 2 free positions (design.py's docstring gives (R) and the
box bound's derivation). Every box bound is a proof for every array in the box; the bound
returned is min(incumbent, least open box), valid whenever the budget ends."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from uav_insar_planner.tomography.array_factor import AMBIGUITY_LEVEL
from uav_insar_planner.tomography.design import GRID_PER_CELL

BOUND_TIME_S = 10.0        # the branch and bound's budget [s]
BOUND_MAX_BOXES = 300_000  # open boxes kept at most
BATCH = 1024               # boxes split at once (best first)
GAP_DB = 0.01              # stop when the least open box is this close to the incumbent
BISECTIONS = 50


@dataclass(frozen=True)
class Bound:
    """A certified lower bound on (R)'s ISLR [dB] (None: no finite bound proven), whether the
    search closed (no open box below the incumbent less GAP_DB), boxes bounded, seconds."""

    islr_db: float | None
    closed: bool
    boxes: int
    seconds: float


def _dsinc(x: np.ndarray) -> np.ndarray:
    """d/dx sinc(x), sinc(x) = sin(pi x)/(pi x); 0 at 0."""
    safe = np.where(x == 0.0, 1.0, x)
    return np.where(x == 0.0, 0.0, (np.cos(np.pi * safe) - np.sinc(safe)) / safe)


def _energy_terms(shape: np.ndarray, half: np.ndarray, a: np.ndarray):
    """E(a) at the centre shapes (M, N), its gradient (M, N) and the second-order remainder
    (M,) over the boxes of half-widths `half` (M, N), each box at its own a (M,)."""
    n = shape.shape[1]
    d = shape[:, :, None] - shape[:, None, :]
    a3 = a[:, None, None]
    value = np.sum(2.0 * a3 * np.sinc(2.0 * a3 * d), axis=(1, 2)) / n**2
    grad = 2.0 * np.sum(4.0 * a3**2 * _dsinc(2.0 * a3 * d), axis=2) / n**2
    spread = half[:, :, None] + half[:, None, :]
    np.einsum("mii->mi", spread)[:] = 0.0
    rest = np.sum(curvature(a3, np.maximum(np.abs(d) - spread, 0.0)) / 2.0 * spread**2,
                  axis=(1, 2)) / n**2
    return value, grad, rest


def curvature(a: np.ndarray, dmin: np.ndarray) -> np.ndarray:
    """A bound on |f''(D)| for |D| >= dmin, f(D) = sin(k D)/(pi D), k = 2 pi a: the lesser of
    int_{-a}^{a} (2 pi h)^2 dh = 8 pi^2 a^3 / 3 and, from f'' = -k^2 sin(kD)/(pi D) -
    2k cos(kD)/(pi D^2) + 2 sin(kD)/(pi D^3), k^2/(pi D) + 2k/(pi D^2) + 2/(pi D^3)."""
    k = 2.0 * math.pi * a
    whole = 8.0 * math.pi**2 * a**3 / 3.0
    with np.errstate(divide="ignore"):
        far = (k * k / dmin + 2.0 * k / dmin**2 + 2.0 / dmin**3) / math.pi
    return np.minimum(whole, far)


def box_bounds(lo: np.ndarray, hi: np.ndarray, aperture: float, span: float,
               ambiguity_min: float) -> tuple[np.ndarray, np.ndarray]:
    """(lower bound on ISLR + 1 (M,), infeasible (M,)) of the boxes [lo, hi] (M, N - 2)."""
    m = lo.shape[0]
    zero, end = np.zeros((m, 1)), np.full((m, 1), aperture)
    shape = np.hstack([zero, 0.5 * (lo + hi), end])
    half = np.hstack([zero, 0.5 * (hi - lo), zero])
    h = np.arange(0.0, max(span, ambiguity_min) + 1e-12, 1.0 / (aperture * GRID_PER_CELL))
    ph = 2.0 * np.pi * shape[:, :, None] * h[None, None, :]
    af = np.hypot(np.cos(ph).mean(axis=1), np.sin(ph).mean(axis=1))
    err = 2.0 * np.pi * h[None, :] * half.sum(axis=1)[:, None] / shape.shape[1]
    low, up = np.maximum(af - err, 0.0), np.minimum(af + err, 1.0)
    before = np.minimum.accumulate(up, axis=1)
    rise = np.zeros_like(low, dtype=bool)
    rise[:, 1:] = before[:, :-1] < low[:, 1:]
    found = rise.any(axis=1)
    hc = np.where(found, h[rise.argmax(axis=1)], np.inf)
    amb = (h[None, :] > hc[:, None]) & (h[None, :] < ambiguity_min) & (low >= AMBIGUITY_LEVEL)
    infeasible = amb.any(axis=1)
    a1 = np.where(found, hc, span)
    es, gs, rs = _energy_terms(shape, half, np.full(m, span))
    e1, g1, r1 = _energy_terms(shape, half, a1)

    def psi(t: np.ndarray) -> np.ndarray:
        lin = np.sum(np.abs(gs - t[:, None] * g1) * half, axis=1)
        return es - t * e1 - lin - rs - t * r1

    ok, top = np.zeros(m), es / np.maximum(e1 - np.sum(np.abs(g1) * half, 1) - r1, 1e-30) + 1.0
    good = psi(ok) >= 0.0
    for _ in range(BISECTIONS):
        mid = 0.5 * (ok + top)
        yes = psi(mid) >= 0.0
        ok, top = np.where(yes, mid, ok), np.where(yes, top, mid)
    return np.where(good & found, ok, 0.0), infeasible


def certified_bound(n: int, aperture: float, span: float, ambiguity_min: float,
                    incumbent_db: float, budget_s: float = BOUND_TIME_S) -> Bound:
    """Branch and bound on (R) for n receivers (module docstring); best first, in batches."""
    start = time.perf_counter()
    target = 10.0 ** ((incumbent_db - GAP_DB) / 10.0) + 1.0  # ISLR + 1 to beat
    lo, hi = np.zeros((1, n - 2)), np.full((1, n - 2), aperture)
    lb = np.zeros(1)
    boxes = 1
    while lo.shape[0] and time.perf_counter() - start < budget_s:
        if lb.min() >= target or lo.shape[0] > BOUND_MAX_BOXES:
            break
        pick = np.argsort(lb)[:BATCH]
        rest = np.ones(lb.size, dtype=bool)
        rest[pick] = False
        plo, phi = lo[pick], hi[pick]
        axis = np.argmax(phi - plo, axis=1)
        mid = 0.5 * (plo[np.arange(axis.size), axis] + phi[np.arange(axis.size), axis])
        left_hi, right_lo = phi.copy(), plo.copy()
        left_hi[np.arange(axis.size), axis] = mid
        right_lo[np.arange(axis.size), axis] = mid
        clo, chi = np.vstack([plo, right_lo]), np.vstack([left_hi, phi])
        # a sorted point may lie in it, and one with s_1 + s_(N-2) <= L (its mirror image
        # L - s, the same array factor, is otherwise in another box)
        sorted_ok = (np.all(clo[:, :-1] <= chi[:, 1:], axis=1)
                     & (clo[:, 0] + clo[:, -1] <= aperture))
        clo, chi = clo[sorted_ok], chi[sorted_ok]
        clb, bad = box_bounds(clo, chi, aperture, span, ambiguity_min)
        boxes += clo.shape[0]
        keep = ~bad & (clb < target)
        lo, hi = np.vstack([lo[rest], clo[keep]]), np.vstack([hi[rest], chi[keep]])
        lb = np.concatenate([lb[rest], clb[keep]])
    open_min = float(lb.min()) if lb.size else math.inf
    closed = open_min >= target
    best = min(target, open_min)  # every pruned box's bound is >= target
    islr = 10.0 * math.log10(best - 1.0) if best > 1.0 else None
    return Bound(islr, closed, boxes, time.perf_counter() - start)
