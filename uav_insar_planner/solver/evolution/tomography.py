"""The tomographic objective (objective "tomography") on the evolution back end.

For the resolution rho = tomo_resolution_m held and a nearest ambiguity >= H =
tomo_ambiguity_min_m, minimise the ISLR over |h| <= S = tomo_height_span_m subject to C1 and
C3-C7, C9-C11 (C2 by construction; C8's per-pair h_amb limit gives way to the array's
ambiguity). The array factor depends on the formation only through the shape of its
wavenumbers (tomography/design.py), so the problem splits:

1. the relaxation (R) without the geometry: the best shapes (`design.search`, seeded
   differential evolution, measured exactly) and a certified lower bound on (R)
   (`bound.certified_bound`), which bounds every formation's ISLR at this resolution;
2. a formation that flies the best shape: the master on its C2 line at range r_0, receiver j
   at wavenumber kappa_j - kappa_m (the master is receiver m), i.e. at b_perp,j =
   (kappa_j - kappa_m) lambda r_0 sin(theta_0) along the normal to the master's line of sight,
   anywhere along that line of sight (offset t_j). (r_0, t_j) are searched by seeded
   differential evolution for the largest least scaled slack of C1, C3-C7, C10 (C9, C11 as the
   station disk, solver/problem.py); the shape, its mirror image (the same AF) and each
   receiver as the master are tried, best shape first.

When the first shape flies, its ISLR is (R)'s incumbent and the gap to the bound is a
certificate of the whole problem. When only a later shape flies, the gap is still a valid
bound (the bound is (R)'s), only wider. No formation found is not a proof of infeasibility.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.optimize import differential_evolution

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.solver.power import schedules
from uav_insar_planner.solver.problem import Problem, cartesian_slacks, make_problem
from uav_insar_planner.solver.result import SolverResult
from uav_insar_planner.swarm import MASTER
from uav_insar_planner.tomography.bound import certified_bound
from uav_insar_planner.tomography.design import Design, search

SEED = 0
POPSIZE = 15
GENERATIONS = 80
OFFSET_MAX = 0.5  # |t_j| <= 0.5 r_0 along the line of sight
DROPPED = frozenset({"C8"})


def formation_of(pr: Problem, kappa: np.ndarray, master: int, r0: np.ndarray,
                 offset: np.ndarray) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """UAV -> (x, z) for candidates r0 (S,) and offsets (N - 1, S) (fractions of r_0): the
    master at r_0 on its C2 line, slave i (in order) at the next receiver's b_perp."""
    p = pr.p
    s0, c0 = math.sin(p.theta0), math.cos(p.theta0)
    x0, z0 = p.x_t - r0 * s0, r0 * c0
    scale = model.height_of_ambiguity(p.wavelength, r0, p.theta0, 1.0)  # lambda r_0 sin(th_0)
    others = [j for j in range(kappa.size) if j != master]
    q = {MASTER: (x0, z0)}
    for i, k in enumerate(pr.slaves):
        b = (kappa[others[i]] - kappa[master]) * scale
        t = offset[i] * r0
        q[k] = (x0 + b * c0 + t * s0, z0 + b * s0 - t * c0)
    return q


def least_slack(pr: Problem, q) -> np.ndarray:
    """The least scaled slack of C1, C3-C7, C9-C11 at q (C8 dropped)."""
    return np.min(np.stack([np.broadcast_to(g, np.shape(q[MASTER][0])).astype(float)
                            for name, g in cartesian_slacks(pr, q) if name not in DROPPED]),
                  axis=0)


def _enough(intermediate_result) -> bool:
    """Stop the search once a point meets every slack by 1e-3 (scipy's callback protocol)."""
    return bool(intermediate_result.fun < -1e-3)


def fly(pr: Problem, kappa: np.ndarray, master: int) -> np.ndarray | None:
    """A formation (num_uavs, 2) flying `kappa` with receiver `master` as U0, or None."""
    def f(v: np.ndarray) -> np.ndarray:
        q = formation_of(pr, kappa, master, v[0], v[1:])
        return -np.nan_to_num(least_slack(pr, q), nan=-1e9)

    bounds = [(pr.r0_lo, pr.r0_hi)] + [(-OFFSET_MAX, OFFSET_MAX)] * len(pr.slaves)
    if not pr.r0_lo <= pr.r0_hi:
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        de = differential_evolution(f, bounds, popsize=POPSIZE, maxiter=GENERATIONS,
                                    rng=np.random.default_rng(SEED), polish=False,
                                    vectorized=True, updating="deferred", tol=0.0,
                                    callback=_enough)
    if de.fun > 0.0:
        return None
    q = formation_of(pr, kappa, master, np.array([de.x[0]]), de.x[1:, None])
    out = np.full((pr.p.num_uavs, 2), np.nan)
    for k, (x, z) in q.items():
        out[k] = (float(x[0]), float(z[0]))
    return out


def realise(pr: Problem, designs: list[Design]) -> tuple[int, np.ndarray] | None:
    """(index of the design flown, formation) for the first design that flies, or None."""
    for i, d in enumerate(designs):
        for kappa in (d.kappa, d.kappa.max() - d.kappa[::-1]):
            for master in range(kappa.size):
                if (q := fly(pr, kappa, master)) is not None:
                    return i, q
    return None


def solve_tomography(p: Params, scheme: str) -> SolverResult:
    """The tomographic objective (module docstring); its certificate names the bound."""
    pr = make_problem(p, scheme, "exact")
    n = len(pr.uavs)
    empty = SolverResult(False, np.full((p.num_uavs, 2), np.nan),
                         np.zeros((p.num_uavs, p.num_slots)), 0)
    if n < 3 or pr.fixed_master:
        empty.message = ("tomography: needs three or more UAVs flown and the master on its C2 "
                         f"line (scheme {scheme!r} with {n} UAVs)")
        empty.blocking = ["C2"] if pr.fixed_master else []
        return empty
    aperture = 1.0 / p.tomo_resolution_m
    span, amb = p.tomo_height_span_m, p.tomo_ambiguity_min_m
    designs = search(n, aperture, span, amb)
    if not designs:
        empty.message = (f"tomography: no array of {n} receivers found at resolution "
                         f"{p.tomo_resolution_m:g} m with its nearest ambiguity >= {amb:g} m "
                         "(relaxation search; not a proof)")
        empty.blocking = ["C8"]
        return empty
    bound = certified_bound(n, aperture, span, amb, designs[0].figures.islr_db)
    flown = realise(pr, designs)
    proof = (f"ISLR >= {bound.islr_db:.3f} dB for every formation at resolution "
             f"{p.tomo_resolution_m:g} m" if bound.islr_db is not None
             else "no finite ISLR bound proven")
    how = (f"certified branch and bound on the geometry-free relaxation, {bound.boxes} boxes "
           f"in {bound.seconds:.1f} s, {'closed' if bound.closed else 'budget ended open'}")
    if flown is None:
        empty.message = ("tomography: no formation found that flies any of the best "
                         f"{len(designs)} arrays within C1, C3-C7, C9-C11 (evolution; not a "
                         f"proof); {proof}")
        empty.blocking = ["C3", "C6", "C7", "C10"]
        return empty
    i, q = flown
    islr = designs[i].figures.islr_db
    gap = islr - bound.islr_db if bound.islr_db is not None else math.nan
    figures = {"required_resolution_m": p.tomo_resolution_m, "required_ambiguity_m": amb,
               "height_span_m": span, "islr_db": islr, "islr_lower_bound_db": bound.islr_db,
               "gap_db": gap, "bound_closed": bound.closed, "bound_boxes": bound.boxes,
               "bound_seconds": bound.seconds}
    return SolverResult(True, q, schedules(p, q, scheme), bound.boxes,
                        metrics={"tomography_objective": figures},
                        certificate=f"{proof} ({how}); this plan's ISLR {islr:.3f} dB, gap "
                        f"{gap:.3f} dB", message=f"tomography: array {i + 1} of "
                        f"{len(designs)} searched flies; evolution back end")
