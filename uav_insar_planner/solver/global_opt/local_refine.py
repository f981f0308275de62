"""A local solve of (P) in ray coordinates from a search point: the incumbent made exact.

The branch and bound's incumbents are box centres (or, for K >= 3 slaves, greedy placements),
within the gap of the optimum but not at it. The optimum is a vertex of the constraints: a
slave at theta_max, on the C8 line, at the edge of its station disk or d_min from a neighbour.
SLSQP over the ray coordinates v = (r0, theta_1..theta_K, r_1..r_K) of solver/problem.py,
with every constraint family written as its own smooth inequality (problem.ray_slacks: C1,
C4, C5, C6, C8 and C9-C11's station disk; C2, C3, C7 and the master's own limits are the
variables' bounds), lands on such a vertex in a few iterations.

The result is only a candidate: `refine` re-checks it against the ray model and returns it
only when feasible there and better, so the certificate never depends on SLSQP. Two other
local moves meet the same rule: `follow` carries a sweep's previous vertex to the next point
(Newton on its active constraints), and `polish` is a compass search on the angles where
SLSQP ends off the feasible set.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize, nnls

from uav_insar_planner.solver import rays
from uav_insar_planner.solver.global_opt import slave_sets
from uav_insar_planner.solver.global_opt.kernel import objective_from_normalised, slave_weight
from uav_insar_planner.solver.problem import Problem, pairs, ray_slacks

# C4 may fall short by this fraction of d_min^2 in the re-check (a nanometre at d_min = 1.5 m,
# far inside the independent checker's micrometre).
C4_SLACK = 1e-9
# A range may fall below its ray's lower limit by this fraction: SLSQP ends on vertices where
# a ray's feasible interval shrinks to a point (a slave at a corner of its station disk and
# the C8 line), and rounding can leave that interval empty by a few ulps.
RANGE_SLACK = 1e-10
FD_STEP = 1e-7
# at_kkt: a constraint or bound within KKT_ACTIVE metres of its limit is active; the gradient
# must be matched to KKT_TOL of its norm (far above the forward differences' error).
KKT_ACTIVE = 1e-6
KKT_TOL = 1e-4
# refine stops SLSQP once an iteration moves no coordinate by more than this fraction of its
# magnitude (metres). Its own test also asks the constraints' summed violation below ftol,
# and at ftol = 1e-12 that is the slacks' rounding noise (~1e-13 m each): at a vertex it can
# keep line-searching in place for dozens of iterations (Figure 4's single-baseline point at
# 17 Mbit/s: 31 iterations, 99 evaluations, the point found at the 8th).
STALL = 1e-12


def _split(sc: Problem, v: np.ndarray):
    k_count = len(sc.slaves)
    return v[:, 0], v[:, 1:1 + k_count], v[:, 1 + k_count:]


def _constraints(sc: Problem, v: np.ndarray) -> np.ndarray:
    """g(v) >= 0 for each row of v (m, 1 + 2K): (m, n_constraints), each scaled to metres:
    r_k >= 0, then (P)'s constraints in ray coordinates (problem.ray_slacks)."""
    r0, th, r = _split(sc, v)
    return np.concatenate([r] + [g for _, g in ray_slacks(sc, r0, th, r)], axis=1)


def _objective(sc: Problem, v: np.ndarray) -> np.ndarray:
    r0, th, r = _split(sc, v)
    w = np.sum(slave_weight(sc, r0[:, None], th, r), axis=1, keepdims=True)
    return objective_from_normalised(sc, w)  # (m, 1): one "constraint" row per point


def _with_jacobian(fun, v: np.ndarray):
    """fun at v and its forward-difference Jacobian, all rows in one vectorised call."""
    h = FD_STEP * np.maximum(np.abs(v), 1.0)
    rows = np.vstack([v, v + np.diag(h)])
    vals = fun(rows)
    return vals[0], ((vals[1:] - vals[0]) / h[:, None]).T


def refine(sc: Problem, point, value: float):
    """(value, point, landed): the SLSQP optimum from `point` when the ray model confirms it
    feasible and it is better, else the input unchanged; landed: SLSQP ended at a point the
    ray model accepts (no better one means `point` was already its local optimum).

    The angles are scaled by r0 (metres of arc) so that every variable is in metres, and the
    objective by 1 / value, which lets SLSQP stop at ftol = 1e-12 within a few iterations, or
    where its iterate stalls (STALL)."""
    k_count = len(sc.slaves)
    v0 = np.array([point[0], *point[1], *point[2]], dtype=float)
    # an infeasible start (value inf) is scaled by its objective ignoring the constraints
    norm = value if math.isfinite(value) else float(_objective(sc, v0[None])[0, 0])
    if not np.all(np.isfinite(v0)) or not math.isfinite(norm) or norm <= 0 or v0[0] <= 0:
        return value, point, False
    scale = np.array([1.0] + [v0[0]] * k_count + [1.0] * k_count)
    bounds = ([(sc.r0_lo, sc.r0_hi)] + [(sc.th_lo * v0[0], sc.th_hi * v0[0])] * k_count
              + [(0.0, None)] * k_count)
    cache: dict[bytes, tuple] = {}

    def parts(u):
        key = u.tobytes()
        if key not in cache:
            # objective (column 0) and constraints in one vectorised call with their Jacobian
            fg, dfg = _with_jacobian(lambda w: np.concatenate(
                [_objective(sc, w) / norm, _constraints(sc, w)], axis=1), u / scale)
            dfg = dfg / scale
            cache.clear()
            # copies: SLSQP may write into the arrays it is handed
            cache[key] = (float(fg[0]), dfg[0].copy(), fg[1:].copy(), dfg[1:].copy())
        return cache[key]

    last = [v0 * scale]

    def stalled(intermediate_result):
        x = intermediate_result.x
        if np.all(np.abs(x - last[0]) <= STALL * np.maximum(np.abs(x), 1.0)):
            raise StopIteration  # SLSQP returns this iterate
        last[0] = x

    with np.errstate(all="ignore"):
        res = minimize(lambda u: parts(u)[0], v0 * scale, jac=lambda u: parts(u)[1],
                       method="SLSQP", bounds=bounds,
                       constraints=[{"type": "ineq", "fun": lambda u: parts(u)[2],
                                     "jac": lambda u: parts(u)[3]}],
                       options={"maxiter": 100, "ftol": 1e-12}, callback=stalled)
    cand = checked(sc, res.x / scale)
    if cand is not None and cand[0] < value:
        return cand[0], cand[1], True
    return value, point, cand is not None


def at_kkt(sc: Problem, point) -> bool:
    """Does the feasible search point (r0, angles, ranges) meet the first-order (KKT)
    conditions of (P) in ray coordinates, to finite-difference accuracy? The gradient of the
    objective must be a non-negative combination of the gradients of the constraints and
    variable bounds active there (slack within KKT_ACTIVE metres): then SLSQP from it would
    stop where it starts, and the point is taken as landed without running it."""
    v = np.array([point[0], *point[1], *point[2]], dtype=float)
    if not np.all(np.isfinite(v)) or v[0] <= 0:
        return False
    k_count = len(sc.slaves)
    scale = np.array([1.0] + [v[0]] * k_count + [1.0] * k_count)  # as in refine: metres
    with np.errstate(all="ignore"):
        fg, dfg = _with_jacobian(lambda w: np.concatenate(
            [_objective(sc, w), _constraints(sc, w)], axis=1), v)
    if not np.all(np.isfinite(fg)) or not np.all(np.isfinite(dfg)):
        return False
    grad, g, jac = dfg[0] / scale, fg[1:], dfg[1:] / scale
    lo = np.array([sc.r0_lo] + [sc.th_lo] * k_count) * scale[:1 + k_count]
    hi = np.array([sc.r0_hi] + [sc.th_hi] * k_count) * scale[:1 + k_count]
    x = (v * scale)[:1 + k_count]
    eye = np.eye(len(v))[:1 + k_count]
    cols = [jac[g <= KKT_ACTIVE], eye[x - lo <= KKT_ACTIVE], -eye[hi - x <= KKT_ACTIVE]]
    active = np.concatenate(cols, axis=0)
    if not len(active):
        return bool(np.linalg.norm(grad) <= KKT_TOL * max(np.abs(grad).max(), 1e-300))
    _, residual = nnls(active.T, grad)
    return bool(residual <= KKT_TOL * np.linalg.norm(grad))


# follow: Newton steps on the vertex equations, and their convergence in metres.
FOLLOW_STEPS = 12
FOLLOW_TOL = 1e-10
# One free direction left (a chain sliding along the C8 line): secant steps on the objective's
# derivative along it, to this fraction of the gradient's norm (at_kkt then asks for
# KKT_TOL), the first a probe of SLIDE_PROBE metres.
SLIDE_TOL = 1e-10
SLIDE_PROBE = 1e-3


def follow(before: Problem, sc: Problem, point):
    """(value, point) of `point`'s vertex carried from problem `before` to sc, or None.

    Along a sweep the optimum moves with the parameter but usually keeps its active set: the
    same slaves on the C8 line, at a disk edge or d_min apart. The constraints and variable
    bounds active at `point` in `before` (within KKT_ACTIVE) are solved as equations in sc by
    Newton's method from `point`, with forward-difference Jacobians as at_kkt takes them. One
    equation short of the variables (the optimum slides along a curve, as a chain along the
    C8 line), the curve is followed to where the objective's derivative along it vanishes
    (`_slide`). None unless Newton converges, the ray model accepts the result (accepted, else
    checked) and it meets sc's KKT conditions (at_kkt): a local optimum of sc found without
    SLSQP. A candidate only, as every result here."""
    v = np.array([point[0], *point[1], *point[2]], dtype=float)
    k_count = len(sc.slaves)
    if not np.all(np.isfinite(v)) or v[0] <= 0 or len(v) != 1 + 2 * k_count:
        return None
    with np.errstate(all="ignore"):
        g = _constraints(before, v[None])[0]
        lo = np.array([before.r0_lo] + [before.th_lo] * k_count)
        hi = np.array([before.r0_hi] + [before.th_hi] * k_count)
        x = v[:1 + k_count]
        scale = np.array([1.0] + [v[0]] * k_count)  # metres, as at_kkt measures them
        at_lo, at_hi = (x - lo) * scale <= KKT_ACTIVE, (hi - x) * scale <= KKT_ACTIVE
        rows = np.flatnonzero(g <= KKT_ACTIVE)
        short = len(v) - len(rows) - int((at_lo | at_hi).sum())
        if short not in (0, 1):
            return None
        new_lo = np.array([sc.r0_lo] + [sc.th_lo] * k_count)
        new_hi = np.array([sc.r0_hi] + [sc.th_hi] * k_count)
        free = np.ones(len(v), dtype=bool)
        free[:1 + k_count] = ~(at_lo | at_hi)
        v[:1 + k_count] = np.where(at_lo, new_lo, np.where(at_hi, new_hi, x))
        v = _project(sc, v, rows, free) if short == 0 else _slide(sc, v, rows, free)
    if v is None:
        return None
    # The ray model's direct verdict first: the inner solve at v's angles (checked) costs a
    # third of a follow, and where the vertex is accepted as it is it gave the same value on
    # every followed point of both figure sweeps (within 2e-12).
    got = accepted(sc, (v[0], v[1:1 + k_count], v[1 + k_count:]))
    cand = checked(sc, v) if got is None else (value_at(sc, got), got)
    if cand is None or not at_kkt(sc, cand[1]):
        return None
    return cand


def _project(sc: Problem, v: np.ndarray, rows: np.ndarray, free: np.ndarray, out=None):
    """v moved (in its `free` coordinates) by Newton's method onto g_rows(v) = 0 of sc, with
    least-norm steps where fewer rows than free coordinates; None unless it converges. out:
    a list that receives the rows' Jacobian over the free coordinates at the result."""
    for _ in range(FOLLOW_STEPS):
        gv, jac = _with_jacobian(lambda w: _constraints(sc, w), v)
        res = gv[rows]
        if not np.all(np.isfinite(res)) or not np.all(np.isfinite(jac[rows])):
            return None
        if np.max(np.abs(res)) <= FOLLOW_TOL:
            if out is not None:
                out.append(jac[rows][:, free])
            return v
        v[free] += np.linalg.lstsq(jac[rows][:, free], -res, rcond=None)[0]
    return None


def _slide(sc: Problem, v: np.ndarray, rows: np.ndarray, free: np.ndarray):
    """On the curve g_rows = 0 (one free direction), the point where the objective's
    derivative along the curve vanishes, by secant steps from v; None when Newton leaves the
    curve or the secant does not converge in FOLLOW_STEPS."""
    t_prev, s_prev, d_prev, s = None, 0.0, 0.0, 0.0
    for _ in range(FOLLOW_STEPS):
        jacs: list[np.ndarray] = []
        if _project(sc, v, rows, free, jacs) is None:
            return None
        t = np.linalg.svd(jacs[0])[2][-1]  # the curve's tangent in the free coordinates
        if t_prev is not None and t @ t_prev < 0:
            t = -t
        _, grad = _with_jacobian(lambda w: _objective(sc, w), v)
        grad = grad[0, free]
        d = float(t @ grad)
        if not math.isfinite(d):
            return None
        if abs(d) <= SLIDE_TOL * np.linalg.norm(grad):
            return v
        step = -math.copysign(SLIDE_PROBE, d) if t_prev is None else \
            -d * (s - s_prev) / (d - d_prev)
        if not math.isfinite(step):
            return None
        t_prev, s_prev, d_prev, s = t, s, d, s + step
        v[free] += step * t
    return None


def from_box(sc: Problem, box: np.ndarray):
    """(value, point) of SLSQP started at the box's centre with every slave at the top of its
    ray (C4 ignored), or (inf, None) when it ends at no point the ray model accepts."""
    r0 = np.array([0.5 * (box[0] + box[1])])
    th = 0.5 * (box[2::2] + box[3::2])
    tops = []
    for j, k in enumerate(sc.slaves):
        lo, up = rays.ray_limits(sc, k, r0, th[j])
        tops.append(float(up[0]) if math.isfinite(up[0]) else float(lo[0]))
    start = (float(r0[0]), tuple(map(float, th)), tuple(tops))
    value, point, landed = refine(sc, start, math.inf)
    return (value, point) if landed and math.isfinite(value) else (math.inf, None)


def accepted(sc: Problem, point) -> tuple | None:
    """The ray model's direct verdict on point (r0, angles, ranges): the point with its angles
    and master range cut to sc's domain and each range to its ray's upper limit, or None when
    a range then falls below its ray's lower limit or two UAVs are closer than d_min (C4), to
    RANGE_SLACK and C4_SLACK."""
    k_count = len(sc.slaves)
    r0 = float(np.clip(point[0], sc.r0_lo, sc.r0_hi))
    th = np.clip(np.asarray(point[1], dtype=float), sc.th_lo, sc.th_hi)
    r = np.array(point[2], dtype=float)
    for j, k in enumerate(sc.slaves):
        lo, up = rays.ray_limits(sc, k, r0, th[j])
        r[j] = min(r[j], float(up))
        if r[j] < lo * (1.0 - RANGE_SLACK):
            return None
    if sc.on("C4"):
        rr, tt = np.concatenate([[r0], r]), np.concatenate([[sc.th0], th])
        q = np.stack([-rr * np.sin(tt), rr * np.cos(tt)], axis=1)  # master first
        i, j = pairs(k_count + 1)
        if np.any(np.sum((q[i] - q[j]) ** 2, axis=1) < sc.p.d_min**2 * (1.0 - C4_SLACK)):
            return None
    return r0, tuple(map(float, th)), tuple(map(float, r))


def value_at(sc: Problem, point) -> float:
    """The objective at point (r0, angles, ranges) of sc (+inf without any baseline)."""
    w = float(np.sum(slave_weight(sc, point[0], np.asarray(point[1], dtype=float),
                                  np.asarray(point[2], dtype=float))))
    return float(objective_from_normalised(sc, w)) if w > 0 else math.inf


def checked(sc: Problem, v: np.ndarray):
    """The ray model's verdict on a point (an SLSQP result, a sweep's witness, both in ray
    coordinates v = (r0, angles, ranges)): (value, point), the ranges cut to the
    ray's limits (`accepted`), or from the inner solve at its angles when that is better;
    None when neither is feasible."""
    k_count = len(sc.slaves)
    r0 = float(np.clip(v[0], sc.r0_lo, sc.r0_hi))
    th = np.clip(v[1:1 + k_count], sc.th_lo, sc.th_hi)
    best = None
    f, ranges = slave_sets.ranges_for(sc, np.array([r0]), th[None])
    if np.isfinite(f[0]):
        best = (float(f[0]), (r0, tuple(map(float, th)), tuple(map(float, ranges[0]))))
    direct = accepted(sc, (v[0], v[1:1 + k_count], v[1 + k_count:]))
    if direct is not None:
        f_direct = value_at(sc, direct)
        if best is None or f_direct < best[0]:
            best = (f_direct, direct)
    return best


def polish(sc: Problem, point, steps, iterations: int = 80):
    """Compass search from `point` on (r0, theta_1, ..., theta_K) with the inner ranges of
    slave_sets.ranges_for: all 3^d stencil points at once, move to the best, halve the step
    when none improves. It only ever returns feasible points no worse than `point` (the
    certificate is unaffected)."""
    k_count = len(sc.slaves)
    lo = np.array([sc.r0_lo] + [sc.th_lo] * k_count)
    hi = np.array([sc.r0_hi] + [sc.th_hi] * k_count)
    x = np.array((point[0], *point[1]))
    step = np.array(steps, dtype=float)
    grid = np.array(np.meshgrid(*[[-1, 0, 1]] * x.size)).reshape(x.size, -1).T  # 3^d stencil
    best = (point_value(sc, point), point)
    for _ in range(iterations):
        cand = np.clip(x + grid * step, lo, hi)
        f, ranges = slave_sets.ranges_for(sc, cand[:, 0], cand[:, 1:])
        i = int(np.argmin(f))
        if f[i] < best[0]:
            x = cand[i]
            best = (float(f[i]), (float(x[0]), tuple(map(float, x[1:])),
                                  tuple(map(float, ranges[i]))))
        else:
            step *= 0.5
            if np.all(step <= 1e-12 * np.maximum(np.abs(x), 1.0)):
                break
    return best


def point_value(sc: Problem, point) -> float:
    """The objective of the search point (r0, angles, ranges) as its inner ranges give it."""
    f, _ = slave_sets.ranges_for(sc, np.array([point[0]]), np.array([point[1]]))
    return float(f[0])
