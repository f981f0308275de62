"""A robust formation built for its worst case: the upper side of the robust problem (P_e).

The worst case of a formation is max over the master's disk of (sum_k min over D_k of
w_k)^(-1/2) (solver/worst_case.py): each slave's term depends on where the master went, so a
good formation is a saddle point, not the nominal optimum of a tightening. In the frame of
solver/robust_bound.py (a along the master's line of sight, c across it, b_perp,k = |c_k|):

- for a master range r_0 each slave sits at the C8 cap |c_k| = c r_0 - e (1 + sqrt(1 + c^2)),
  the largest b_perp whose h_amb holds over the disks (`worst_case.h_amb_worst` is then
  h_amb,k^min), or a little inside it, on either side of the line of sight, at the along-track
  a that a grid (refined about its best) finds;
- every candidate slave point keeps its own families over the disks (`worst_case.slave_slacks`
  >= 0), and its term is tabulated for the master on its rim at `MASTER_ANGLES` and the slave
  at the worst of `RIM_POINTS` points of its own rim (actual positions, the checker's
  formulas);
- each pattern of sides and each master angle picks every slave's best point for that angle
  (slaves on one side kept C4 apart), and the formation is scored by the least over the master
  angles of the summed terms: an estimate of its worst case from positions it can reach;
- r_0 is searched on a grid over the master's range and refined about the best.

Nothing here is a certificate: solver/robust.py checks the formation with
`worst_case.robust_slacks` and bounds its worst case with `worst_case.worst_sigma`, as it does
the tightening's plans, and keeps whichever is certified better.
"""
from __future__ import annotations

import itertools
import math

import numpy as np

from uav_insar_planner.params import Params
from uav_insar_planner.solver.robust_bound import MASTER_ANGLES, Frame, frame, to_xz
from uav_insar_planner.solver.worst_case import pair_sigma, slave_slacks
from uav_insar_planner.swarm import MASTER

RIM_POINTS = 12
A_SPAN_M, A_STEP_M, A_FINE_M = 16.0, 1.0, 0.05
CAP_SHARES = (1.0,)
R0_POINTS = 7
R0_REFINE = 3
INSIDE = 1.0 - 1e-9  # the cap is met with this much to spare, against rounding


def _terms(fr: Frame, k: int, r0: float, a: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(points, len(MASTER_ANGLES)): slave k's worst w_k over its rim, the master on its rim
    at each angle; -inf for a point that breaks one of its families over the disks."""
    p, e = fr.p, fr.p.nav_error_m
    q0 = np.array(to_xz(p, r0, 0.0), dtype=float)
    x, z = to_xz(p, a, c)
    held = slave_slacks(p, q0, x, z, k, fr.scheme)
    ok = np.all([v >= 0 for v in held.values()], axis=0)
    mx, mz = to_xz(p, r0 + e * np.cos(MASTER_ANGLES), e * np.sin(MASTER_ANGLES))
    rim = np.linspace(0.0, 2 * math.pi, RIM_POINTS, endpoint=False)
    xs = x[:, None, None] + e * np.cos(rim)[None, None, :]
    zs = z[:, None, None] + e * np.sin(rim)[None, None, :]
    w = 1.0 / pair_sigma(p, mx[None, :, None], mz[None, :, None], xs, zs) ** 2
    return np.where(ok[:, None], w.min(axis=2), -np.inf)


def _side_points(fr: Frame, k: int, r0: float, side: int, a: np.ndarray | None = None):
    """Candidate (a, c) of slave k on `side` at master range r_0, and their terms."""
    e, s = fr.p.nav_error_m, fr.slope[k]
    cap = (s * r0 - e * (1.0 + math.sqrt(1.0 + s * s))) * INSIDE
    if cap <= 0:
        return np.zeros((0, 2)), np.zeros((0, len(MASTER_ANGLES)))
    if a is None:
        a = np.arange(max(r0 - A_SPAN_M, e), r0 + A_SPAN_M, A_STEP_M)
    pts = np.array([(ai, side * cap * f) for f in CAP_SHARES for ai in a])
    return pts, _terms(fr, k, r0, pts[:, 0], pts[:, 1])


def _assemble(fr: Frame, r0: float, table: dict, sides, angle: int):
    """Each slave's best point for the master angle `angle`, slaves C4 apart; None if none."""
    p, e = fr.p, fr.p.nav_error_m
    chosen, total = [], np.zeros(len(MASTER_ANGLES))
    for k, side in zip(fr.slaves, sides, strict=True):
        pts, terms = table[k, side]
        order = np.argsort(-terms[:, angle]) if len(pts) else []
        pick = next((i for i in order if np.isfinite(terms[i, angle]) and all(
            math.dist(pts[i], q) >= p.d_min + 2 * e for q in chosen)), None)
        if pick is None:
            return None
        chosen.append(pts[pick])
        total = total + terms[pick]
    return float(total.min()), chosen


def _best_at(fr: Frame, r0: float):
    """(worst-case estimate^-2, slave points) of the best assembly at master range r_0."""
    table = {(k, s): _side_points(fr, k, r0, s) for k in fr.slaves for s in (-1, 1)}
    best = (-math.inf, None, None)
    for sides in itertools.product((-1, 1), repeat=len(fr.slaves)):
        for angle in range(len(MASTER_ANGLES)):
            got = _assemble(fr, r0, table, sides, angle)
            if got is not None and got[0] > best[0]:
                best = (got[0], got[1], (sides, angle))
    if best[1] is None:
        return best
    sides, angle = best[2]
    fine = {}
    for (k, side), q in zip(zip(fr.slaves, sides, strict=True), best[1], strict=True):
        a = np.arange(q[0] - A_STEP_M, q[0] + A_STEP_M, A_FINE_M)
        fine[k, side] = _side_points(fr, k, r0, side, a)
    got = _assemble(fr, r0, fine, sides, angle)
    return got + (best[2],) if got is not None and got[0] > best[0] else best


def search(p: Params, scheme: str) -> np.ndarray | None:
    """The formation (rows x, z; NaN for a UAV not flown) of the best worst-case estimate over
    the master's range (module docstring), or None when the frame does not apply or no
    candidate keeps every family."""
    fr = frame(p, scheme)
    if fr is None or not fr.slaves or fr.r0_range[0] > fr.r0_range[1]:
        return None
    lo, hi = fr.r0_range
    grid = list(np.linspace(lo, min(hi, 2.0 * lo), R0_POINTS)) if hi > lo else [lo]
    scored = {r0: _best_at(fr, r0) for r0 in grid}
    step = grid[1] - grid[0] if len(grid) > 1 else 0.0
    for _ in range(R0_REFINE if step else 0):
        r_best = max(scored, key=lambda r: scored[r][0])
        step /= 3.0
        for r0 in (r_best - step, r_best + step):
            if lo <= r0 <= hi and r0 not in scored:
                scored[r0] = _best_at(fr, r0)
    r_best = max(scored, key=lambda r: scored[r][0])
    value, points, _ = scored[r_best]
    if points is None:
        return None
    out = np.full((p.num_uavs, 2), np.nan)
    out[MASTER] = to_xz(p, r_best, 0.0)
    for k, (a, c) in zip(fr.slaves, points, strict=True):
        out[k] = to_xz(p, a, c)
    return out
