"""Robust plans: every UAV anywhere within e = nav_error_m of its planned point.

The robust problem (P_e). A formation q is robust-feasible when C1 and C3-C11 hold at every
q' with ||q_k' - q_k|| <= e for each flown UAV k (the across-track plane), with the plan's own
power schedule; C2 (the master on its look-angle line) binds the planned point only. Its
value is the worst case max over those q' of the fused sigma_h (eq. 15); (P_e) minimises it.

Certified tightening (`tightened`): a nominal problem whose every feasible point is
robust-feasible, written in the scenario's own parameters, so any back end that solves (P)
solves it. With r_0,lo the master's least range and r_lo a slave's (both from the tightened
C1 and C5), a = asin(e / r_lo) and c_k = lambda sin(theta_0) / h_amb,k^min:

- C1: z in [z_min + e, z_max - e]; C4: d_min + 2e (both exact);
- C9-C11: the station disk's radius less e and the schedule sized for rho_k + e
  (solver/power.py; exact);
- C3: [theta_min + a, theta_max - a] (look angles move at most asin(e / r_k) <= a);
- C7: gamma_Rg^min raised to the larger gamma_Rg at the C7 interval's ends moved inwards by a,
  so the new interval lies a inside the old one (gamma_Rg is unimodal, eq. 10);
- C5: S_min + Theta e max(1 / cos(theta_0), 1 / cos^2(theta_max) + 2 / cos(theta_max)):
  the master's swath Theta r_0 / cos(theta_0) loses at most Theta e / cos(theta_0), a slave's
  Theta r^2 / z at most Theta e (r / z) (r / z + 2) (expand r^2 / z - (r - e)^2 / (z + e));
- C6: gamma_SNR^min (1 + e / r_0,lo)^(5/2) (1 + e / r_lo)^(1/2): 1 / gamma_SNR^2 =
  (1 + r_0^3 / gamma_m)(1 + r_0^2 r_k / gamma_m) grows at most by that factor squared when both
  ranges grow by e (eq. 7);
- C8: b_perp,k <= c_k' r_0 with c_k' = c_k - (2 + c_k) e / r_0,lo, so that
  b_perp,k + 2e <= c_k (r_0 - e) for every r_0 >= r_0,lo (b_perp moves at most 2e, r_0 at most
  e); written as h_amb_min = lambda sin(theta_0) / c_1' (the first rung exact) and the least
  h_amb_ratio rho' >= rho with h_amb_min rho'^(k-1) >= lambda sin(theta_0) / c_k' for every k.

The worst case. The nominal optimum over the tightened set keeps the master near its least
range, but the worst case gains from a longer one (b_perp - 2e grows with r_0). So the master's
range floor f (a raised S_min, `tightened(floor_m=f)`) is searched on a grid and the plan with
the least certified worst case (solver/worst_case.py) is returned: `sigma_h_worst_m`, an upper
bound of sigma_h over the disks. Every plan is checked by `worst_case.robust_slacks` before it
is returned, once: the answer keeps the chosen plan's slacks (`RobustAnswer.held`).

Lower bound (the gap). Two relaxations of (P_e), each solved by the back end, whose certified
lower bounds bound (P_e) from below; the larger is reported:

- `relaxed`: C1, C4 and C9-C11 tightened exactly, S_min + Theta e (a UAV moved e towards the
  target keeps its swath only so), everything else nominal; every robust-feasible q is
  feasible for it and its worst case is at least its sigma_h at q.
- `moved_relaxation`: q'' = q with each slave moved e towards the master's line of sight (the
  master stays, so C2 holds). q'' lies in the disks, so it meets the nominal (P), and
  sigma_h(q'') <= the worst case of q; its b_perp,k is b_perp,k - e, where the robust C8 at
  the slave moved e the other way and the master e nearer gives b_perp,k + e <= c_k (r_0 - e),
  so b_perp,k'' <= c_k r_0 - (2 + c_k) e <= c_k'' r_0 with c_k'' = c_k - (2 + c_k) e / R for
  r_0 <= R, the nominal master interval's top (or <= e <= (e / r_0,lo) r_0 when b_perp,k < e).
  So the nominal problem with C8 at c_k'' holds q'' and its optimum bounds the worst case.

Both leave much of the error's effect out, so a third bound is taken with them: the branch
and bound over the master's range of solver/robust_bound.py (its docstring says why it holds).
The upper side likewise gains a formation built for its worst case (solver/robust_search.py,
slaves on either side of the master's line of sight), certified as the floor plans are; the
smaller certified worst case is returned. Gaps and times in docs/science/robust.md.
When the first is proven infeasible, so is (P_e), blocked by its
blocking families; when only the tightening is, the plan is infeasible without a proof.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.solver import power, robust_bound, robust_search
from uav_insar_planner.solver.problem import c7_sines, make_problem
from uav_insar_planner.solver.result import SolverResult
from uav_insar_planner.solver.worst_case import (
    ConstraintStatus,
    WorstCase,
    robust_slacks,
    worst_sigma,
)

# The master-range floors tried: this many on a geometric grid up to the master interval's top
# (at most FLOOR_SPAN times the least range), then as many between the best's neighbours.
FLOOR_POINTS = 5
FLOOR_SPAN = 3.0
SEARCH_TOL = 1e-2  # worst-case bound's tolerance while searching; WORST_TOL at the end
ALMOST_ONE = 1.0 - 1e-12
# The lower bound's branch and bound stops once it is within this share of the plan's worst case.
BOUND_TOL = 5e-3

Backend = Callable[[Params, str, str], SolverResult]


@dataclass(frozen=True)
class RobustAnswer:
    """The back end's answer for the chosen tightening, and the worst-case figures."""

    result: SolverResult
    worst: WorstCase | None
    lower_bound: float
    certificate: str
    #: robust_slacks of `result`'s plan, computed once while searching; None with no plan.
    held: dict[str, ConstraintStatus] | None = None


def _master_least_range(p: Params, scheme: str) -> float:
    """r_0,lo: the fixed master's own range, else the least the tightened C1 and C5 allow."""
    if scheme == "fixed-master":
        return math.hypot(p.master_fixed[0] - p.x_t, p.master_fixed[1])
    c0 = math.cos(p.theta0)
    return max(p.z_min / c0, p.swath_min * c0 / p.beamwidth)


def tightened(p: Params, scheme: str, floor_m: float = 0.0) -> Params:
    """The certified tightening of (P) for p.nav_error_m (module docstring), with the master's
    range at least floor_m. e = 0 and no floor: p itself."""
    e = p.nav_error_m
    if e == 0.0 and floor_m == 0.0:
        return p
    c0, cmax = math.cos(p.theta0), math.cos(p.theta_max)
    swath = p.swath_min + p.beamwidth * e * max(1.0 / c0, 1.0 / cmax**2 + 2.0 / cmax)
    swath = max(swath, p.beamwidth * floor_m / c0)
    z_min = p.z_min + e
    t = replace(p, z_min=z_min, z_max=p.z_max - e, d_min=p.d_min + 2.0 * e, swath_min=swath)
    r0_lo = _master_least_range(t, scheme)
    r_lo = max(z_min, swath * cmax / p.beamwidth)
    a = math.asin(min(e / r_lo, 1.0))
    snr = p.coherence_snr_min * (1.0 + e / r0_lo) ** 2.5 * (1.0 + e / r_lo) ** 0.5
    h_amb_min, h_amb_ratio = _c8_raised(p, e, r0_lo)
    return replace(t, theta_min=p.theta_min + a, theta_max=p.theta_max - a,
                   coherence_rg_min=_c7_raised(p, a), coherence_snr_min=min(snr, ALMOST_ONE),
                   h_amb_min=h_amb_min, h_amb_ratio=h_amb_ratio)


def _c7_raised(p: Params, a: float) -> float:
    """gamma_Rg^min whose C7 interval lies a inside p's (module docstring)."""
    sines = c7_sines(p)
    if sines is None or a == 0.0:
        return p.coherence_rg_min
    bp = p.fractional_bandwidth
    ends = [math.asin(min(sines[0], 1.0)) + a]
    if sines[1] < 1.0:
        ends.append(math.asin(sines[1]) - a)
    if ends[0] > p.theta0 or (len(ends) > 1 and ends[1] < p.theta0):
        return ALMOST_ONE  # nothing is left of the interval
    raised = max(float(model.coherence_baseline(model.chi(p.theta0, t), bp)) for t in ends)
    return min(max(raised, p.coherence_rg_min), ALMOST_ONE)


def _c8_raised(p: Params, e: float, r0_lo: float) -> tuple[float, float]:
    """(h_amb^min, h_amb_ratio) with b_perp,k + 2e <= c_k (r_0 - e) for every r_0 >= r0_lo
    (module docstring): the first rung exact, the ratio the least that covers the others."""
    if e == 0.0:
        return p.h_amb_min, p.h_amb_ratio
    s = p.wavelength * math.sin(p.theta0)
    need = []
    for k in range(1, p.num_uavs):
        c = s / model.h_amb_min_of(p, k)
        c_new = c - (2.0 + c) * e / r0_lo
        if c_new <= 0.0:
            return math.inf, p.h_amb_ratio  # no baseline survives: C8 leaves nothing
        need.append(s / c_new)
    ratio = max([p.h_amb_ratio] + [(h / need[0]) ** (1.0 / j) for j, h in enumerate(need) if j])
    return need[0], ratio


def relaxed(p: Params) -> Params:
    """A relaxation of (P_e) (module docstring): C1, C4, C9-C11 exact, S_min + Theta e."""
    e = p.nav_error_m
    return replace(p, z_min=p.z_min + e, z_max=p.z_max - e, d_min=p.d_min + 2.0 * e,
                   swath_min=p.swath_min + p.beamwidth * e)


def moved_relaxation(p: Params, scheme: str, objective: str) -> Params:
    """The nominal problem that every slave-moved formation q'' obeys (module docstring):
    C8 at c_k'' = max(c_k - (2 + c_k) e / R, e / r_0,lo), R and r_0,lo the nominal master
    interval's ends, as (h_amb_min, h_amb_ratio); p with e = 0 otherwise."""
    e = p.nav_error_m
    nominal = replace(p, nav_error_m=0.0)
    pr = make_problem(nominal, scheme, objective)
    if not 0.0 < pr.r0_lo <= pr.r0_hi < math.inf:
        return nominal
    s = p.wavelength * math.sin(p.theta0)
    caps = [max(c - (2.0 + c) * e / pr.r0_hi, e / pr.r0_lo)
            for c in (s / model.h_amb_min_of(p, k) for k in range(1, p.num_uavs))]
    ratio = min([(caps[0] / c) ** (1.0 / j) for j, c in enumerate(caps) if j], default=1.0)
    return replace(nominal, h_amb_min=s / caps[0], h_amb_ratio=max(ratio, 1.0))


def _floors(p: Params, scheme: str, objective: str) -> list[float]:
    pr = make_problem(tightened(p, scheme), scheme, objective)
    if pr.fixed_master or not pr.r0_lo < pr.r0_hi:
        return [0.0]
    top = min(pr.r0_hi, pr.r0_lo * FLOOR_SPAN)
    return [float(f) for f in np.geomspace(pr.r0_lo, top, FLOOR_POINTS)]


def solve(p: Params, scheme: str, objective: str, run: Backend) -> RobustAnswer:
    """The robust plan for p.nav_error_m > 0 by the back end `run` (module docstring)."""
    relax = run(relaxed(p), scheme, objective)
    if not relax.feasible and relax.lower_bound == math.inf:
        return RobustAnswer(replace(relax, message=(
            f"no formation keeps C1, C3-C11 with every UAV anywhere within "
            f"{p.nav_error_m:g} m of its point: " + relax.message)), None, math.inf,
            "robust problem infeasible: its relaxation (C1, C4, C5, C9-C11 tightened by e) "
            f"is: {relax.certificate}")
    tried: dict[float, tuple[float, SolverResult, WorstCase,
                             dict[str, ConstraintStatus]] | None] = {}

    def attempt(floor: float) -> None:
        res = run(tightened(p, scheme, floor), scheme, objective)
        if not res.feasible:
            tried[floor] = None
            return
        held = robust_slacks(p, res.formation, res.p_com, scheme)
        worst = worst_sigma(p, res.formation, scheme, SEARCH_TOL)
        tried[floor] = (worst.upper, res, worst, held) if all(
            c.ok for c in held.values()) else None

    grid = _floors(p, scheme, objective)
    for f in grid:
        attempt(f)
    done = {f: v for f, v in tried.items() if v is not None}
    if not done:
        first = run(tightened(p, scheme), scheme, objective)
        return RobustAnswer(replace(first, feasible=False, message=(
            "no formation of the certified tightening survives the navigation error; not "
            "proven infeasible (the relaxation has one)")), None, relax.lower_bound,
            "robust problem: no plan found, infeasibility not proven")
    best = min(done, key=lambda f: done[f][0])
    i = grid.index(best)
    for f in np.linspace(grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)], FLOOR_POINTS):
        if float(f) not in tried:
            attempt(float(f))
    done = {f: v for f, v in tried.items() if v is not None}
    _, res, _, held = done[min(done, key=lambda f: done[f][0])]
    worst = worst_sigma(p, res.formation, scheme)
    built = _built(p, scheme, objective)
    if built is not None and built[1].upper < worst.upper:
        res, worst, held = built
    # the relaxations bound sigma_h only when sigma_h is what the back end minimised
    lower = math.nan
    if objective == "exact":
        lower = max(relax.lower_bound,
                    run(moved_relaxation(p, scheme, objective), scheme, objective).lower_bound)
        lower = float(np.nanmax([lower, robust_bound.lower_bound(
            p, scheme, worst.upper * (1.0 - BOUND_TOL))]))
    return RobustAnswer(res, worst, lower, (
        f"branch and bound over {worst.squares} squares of the master's error disk, each "
        "slave's disk by monotone bounds"), held)


def _built(p: Params, scheme: str, objective: str
           ) -> tuple[SolverResult, WorstCase, dict[str, ConstraintStatus]] | None:
    """robust_search's formation for the exact objective, as a plan with its power schedules,
    its slacks over the disks and its certified worst case; None if it fails them."""
    if objective != "exact":
        return None
    q = robust_search.search(p, scheme)
    if q is None:
        return None
    p_com = power.schedules(p, q, scheme)
    held = robust_slacks(p, q, p_com, scheme)
    if not all(c.ok for c in held.values()):
        return None
    worst = worst_sigma(p, q, scheme)
    return SolverResult(True, q, p_com, 0, certificate=(
        "built for its worst case (solver/robust_search.py): no certificate of the nominal "
        "problem")), worst, held
