"""Survey speed v_y as a decision variable: the fastest speed for an accuracy, and the front.

Where v_y enters (P). gamma_m = sigma_0 P_t G_t G_r lambda^3 c tau_p PRF / (4^4 pi^3 v_y ...)
(after eq. 8) falls as 1/v_y, and with it both SNRs (eqs. 8-9) and gamma_SNR,k (eq. 7): a
formation's sigma_h (eqs. 13-15) rises with v_y, and C6 (gamma_SNR,k >= gamma_SNR^min) admits
fewer formations. The track y[n] = (n - 1) v_y delta_t (eq. 1) sets the UAV-station distance of
every slot, so C9-C11 read v_y too: C10 must hold in the slot farthest from the station at a
power within C9, which is y[1] = 0 while (N - 1) v_y delta_t <= 2 g_y and the track's end past
that (Table I: v_y > 2 x 149.37 m / 79 s = 3.78 m/s), moving away as v_y grows. Survey time,
for an area, falls as 1/v_y. So faster costs accuracy, and (P) becomes infeasible.

Measured at Table I (the certified global optimum, exact objective, scheme `proposed`;
`python benchmarks/survey_speed_front.py --scan`, 95 warm solves at 0.05..4.75 m/s in 1.2-1.8 s,
plus the bisection of the edge to 1e-4 m/s and the blocking sets past it):

    v_y [m/s]   0.01    0.5     1       2       3       4.3     4.7     4.75    4.7594
    sigma_h [m] 0.06512 0.06630 0.06756 0.06963 0.07140 0.07364 0.07432 0.07877 0.07981

- feasible on [0.01, 4.7594] m/s (0.01 is the speed_mps spec's floor), infeasible past it;
- the upper edge is C9 + C10 at the track's end (the irreducible infeasible set just past it
  is C3 + C5 + C9 + C10: the station disk the far slot allows no longer meets the look-angle
  and swath region); C9 + C10 alone block up to 15 m/s, from 15.5 m/s C3 + C5 + C6 (the SNR
  of C6 too low for any formation the swath allows), C5 + C6 at 100 and 1000 m/s;
- sigma_h increases with v_y over the whole feasible range: at every step of the 0.05 m/s
  scan the certified lower bound exceeds the previous point's sigma_h. Up to 4.7 m/s the rise
  is the SNR's (about 2 % per m/s, C9 slack > 0); from 4.72 m/s C9 binds at the far slot and
  reshapes the formation (+6 % between 4.74 and 4.75 m/s).

Why monotone, and when it may not be: sigma_h of a fixed formation rises with v_y (gamma_m);
C6 only tightens; C9/C10 leave the same set while y[1] is the farthest slot and tighten past
it; C11 (sum of the slots' powers) may loosen as the slots come nearer the station. So while
C11 does not bind (Table I: 283 J of slack at the edge), the feasible set shrinks and the
optimum rises: sigma_h*(v) is non-decreasing. With C11 binding it need not be, so the
searches below verify their answers with a certified solve at 1.05 v rather than trust it.

Certified. A speed meets a target when its plan is feasible and its sigma_h <= target (a
formation exists, independently checked); a speed is refuted when its certified lower bound
exceeds the target (inf when (P) is proven infeasible): then no formation at that speed meets
it. `fastest_speed` returns a speed that meets the target together with the refutation of
1.05 x that speed (or v_max itself, when it meets: the airframe bounds the speed). Under
nav_error_m > 0 the worst-case sigma_h and its lower bound (solver/robust.py) play these roles;
their gap is wide (19-21 % at e = 0.3 m, Table I), so a target the accuracy bounds is then
mostly reported uncertifiable (SpeedSearchError naming the gap) rather than answered.

The solves of one search share one warm start (solver.new_warm_start, as a sweep's chain):
nothing carried is used at the new speed unproven there (solver/global_opt/warm.py), so the
order of the speeds only changes the route, not the certificate. What a speed step carries
(solver/global_opt/speed_carry.py): the previous optimum, followed to the new speed; a step
up past the speed where C11's disk stops growing (Table I: 2.82 m/s) restricts (P), so the
previous proofs of infeasibility and box bounds hold as they are (warm.speed_restricts);
where the optimum stays (its vertex at theta_max past 3 m/s), a step up or down carries the
previous box bounds scaled by a factor rho_B proven box by box (sigma_h rises about 0.6 % a
0.25 m/s step, so the bounds as they are would close little); where it slides with v (the
flat optimum below 2.75 m/s), the previous boxes move with it, each bounded afresh.
Measured on the 23-point front (median of 3 rounds, load average 1.4-5.6 on 2 cores, six
runs): warm 0.60-0.67 x cold, 191-222 vs 310-365 ms
(`python benchmarks/survey_speed_front.py --repeats 3`); the 0.5 the issue asks is not
reached: at 1-2.5 m/s the certificate of a flat optimum needs some 10 000 boxes at the new
speed whatever the start (carrying a bound costs a third to a whole fresh one), and a
failed follow (an active set that changes: 1, 2.75, 4.75 m/s) costs its 3 ms on top of the
cold route.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from uav_insar_planner.param_specs.science import BACKEND_BY_NAME, BACKENDS, SPEC_BY_NAME
from uav_insar_planner.params import Params
from uav_insar_planner.plan import Plan
from uav_insar_planner.solver import new_warm_start, solve

SPEED_SPEC = SPEC_BY_NAME["speed_mps"]
# The evidence's step: a speed is certified fastest when 1.05 x it is refuted, so the answer
# is within 5 % of the true fastest speed even where the tolerance alone would be finer.
EVIDENCE_FACTOR = 1.05
# The bisection stops once its bracket is within tol and within half the evidence's step, so
# that 1.05 v lies past the first refuted speed (and away from the solver's gap).
BRACKET_FACTOR = 1.0 + (EVIDENCE_FACTOR - 1.0) / 2.0
TOL_MPS = 0.01
# Bisection steps at most (the bracket halves each step: 1000 m/s to 1e-9 m/s).
MAX_STEPS = 60


class SpeedSearchError(ValueError):
    """A speed search with no answer in its range, as one line: field, value, what is allowed."""


@dataclass(frozen=True)
class Evidence:
    """The certified solve at a speed next to the answer: feasible, its sigma_h (NaN when
    infeasible), its certified lower bound (inf when proven infeasible) and what blocks it."""

    speed_mps: float
    feasible: bool
    sigma_h_m: float
    lower_bound_m: float
    blocking: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class SpeedChoice:
    """The chosen speed, its certified plan, why (one line) and the evidence at 1.05 x the
    speed (None when v_max itself was chosen). `solves`: certified solves spent."""

    speed_mps: float
    plan: Plan
    why: str
    above: Evidence | None = None
    solves: int = 0


@dataclass(frozen=True)
class FrontPoint:
    """One certified point of the accuracy-speed front."""

    speed_mps: float
    feasible: bool
    sigma_h_m: float
    lower_bound_m: float
    optimality_gap: float
    blocking: tuple[str, ...]
    solve_time_s: float


def upper_m(plan: Plan) -> float:
    """The plan's sigma_h: the certified worst case under a navigation error, else nominal."""
    return plan.sigma_h_worst_m if plan.nav_error_m > 0.0 else plan.sigma_h_m


def lower_m(plan: Plan) -> float:
    """The certified lower bound of the optimum matching `upper_m` (inf: proven infeasible)."""
    return plan.worst_lower_bound_m if plan.nav_error_m > 0.0 else plan.lower_bound_m


def gap(plan: Plan) -> float:
    """The certified relative gap of `upper_m` over `lower_m`."""
    return plan.worst_gap if plan.nav_error_m > 0.0 else plan.optimality_gap


def meets(plan: Plan, target_m: float) -> bool:
    """A formation at this speed holds (P) and sigma_h <= target (independently checked)."""
    return plan.feasible and upper_m(plan) <= target_m


def refuted(plan: Plan, target_m: float) -> bool:
    """No formation at this speed meets the target: the certified lower bound is above it
    (inf when (P) is proven infeasible; NaN, no certificate, refutes nothing)."""
    return lower_m(plan) > target_m


def evidence(plan: Plan, speed_mps: float) -> Evidence:
    return Evidence(speed_mps, plan.feasible, upper_m(plan) if plan.feasible else float("nan"),
                    lower_m(plan), tuple(plan.blocking_constraints))


class Chain:
    """Certified solves of one scenario at several speeds, sharing one warm start (or none:
    `warm=False`), each speed solved once."""

    def __init__(self, params: Params, warm: bool = True):
        self.params = params
        self.warm = new_warm_start(params.solver) if warm else None
        self.plans: dict[float, Plan] = {}

    def __call__(self, speed_mps: float) -> Plan:
        v = float(speed_mps)
        if v not in self.plans:
            self.plans[v] = solve(self.params.replace(speed_mps=v), warm_start=self.warm)
        return self.plans[v]


def check_range(params: Params, v_max_mps: float, tol: float,
                v_min_mps: float | None) -> float:
    """v_min (default the speed_mps spec's floor), after checking the solver is certified and
    v_min < v_max within the spec's range; a one-line SpeedSearchError otherwise."""
    certified = [b.name for b in BACKENDS if b.certified]
    if not BACKEND_BY_NAME[params.solver].certified:
        raise SpeedSearchError(f"solver: value {params.solver!r} is not allowed; a speed search "
                               f"needs a certified lower bound: one of {', '.join(certified)}")
    v_min = SPEED_SPEC.lo if v_min_mps is None else float(v_min_mps)
    lo, hi = SPEED_SPEC.lo, SPEED_SPEC.hi
    for field, value in (("v_min_mps", v_min), ("v_max_mps", float(v_max_mps))):
        if not lo <= value <= hi:
            raise SpeedSearchError(f"{field}: value {value:g} is not allowed; expected "
                                   f"{lo:g}..{hi:g} m/s (speed_mps)")
    if not v_min < v_max_mps:
        raise SpeedSearchError(f"v_max_mps: value {v_max_mps:g} is not allowed; expected above "
                               f"v_min_mps {v_min:g} m/s (an empty speed range)")
    if not tol > 0.0:
        raise SpeedSearchError(f"tol: value {tol:g} is not allowed; expected > 0 m/s")
    return v_min


def bisect(ok: Callable[[float], bool], lo: float, hi: float, tol: float) -> tuple[float, float]:
    """Shrink [lo, hi] with ok(lo) and not ok(hi) until hi - lo <= tol and hi <= lo x
    BRACKET_FACTOR, keeping those two ends (the boundary of a monotone `ok` stays inside)."""
    for _ in range(MAX_STEPS):
        if hi - lo <= tol and hi <= lo * BRACKET_FACTOR:
            break
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo, hi


def bracket(run: Chain, target_m: float, v_min: float, v_max: float) -> float | None:
    """A speed that meets the target, halving down from v_max (v_max fails) to v_min; None
    when none of those does, v_min included."""
    v = 0.5 * v_max
    while v > v_min:
        if meets(run(v), target_m):
            return v
        v *= 0.5
    return v_min if meets(run(v_min), target_m) else None


def fastest_speed(params: Params, sigma_h_max_m: float, v_max_mps: float, tol: float = TOL_MPS,
                  *, v_min_mps: float | None = None) -> SpeedChoice:
    """The fastest v in [v_min, v_max] (m/s) whose certified optimum keeps sigma_h <=
    sigma_h_max_m (the least survey time for that accuracy), within tol and 5 %: bracketing
    down from v_max, bisection, then the certified refutation of 1.05 v (module docstring)."""
    v_min = check_range(params, v_max_mps, tol, v_min_mps)
    target, v_max = float(sigma_h_max_m), float(v_max_mps)
    if not target > 0.0:
        raise SpeedSearchError(f"sigma_h_max_m: value {sigma_h_max_m!r} is not allowed; "
                               "expected a height accuracy > 0 m")
    run = Chain(params)
    top = run(v_max)
    if meets(top, target):
        return SpeedChoice(v_max, top, f"v_max_mps {v_max:g} m/s meets sigma_h "
                           f"{upper_m(top):.5g} <= {target:.5g} m: the airframe bounds the "
                           "speed, not the accuracy", None, len(run.plans))
    lo = bracket(run, target, v_min, v_max)
    if lo is None:
        raise SpeedSearchError(unreachable(run, target, v_min, v_max))
    hi = v_max
    for _ in range(MAX_STEPS):
        lo, hi = bisect(lambda v: meets(run(v), target), lo, hi, tol)
        v_ev = min(EVIDENCE_FACTOR * lo, SPEED_SPEC.hi)
        if refuted(run(v_ev), target):
            break
        if not meets(run(v_ev), target) or v_ev >= v_max:
            raise SpeedSearchError(
                f"sigma_h_max_m: value {target:g} m cannot be certified: at {v_ev:.4g} m/s "
                f"(1.05 x {lo:.4g}) the optimum lies in [{lower_m(run(v_ev)):.6g}, "
                f"{upper_m(run(v_ev)):.6g}] m; allowed: a target outside that gap")
        lo, hi = v_ev, v_max  # sigma_h not monotone here: 1.05 v meets it, search above
    else:
        raise SpeedSearchError(f"sigma_h_max_m: value {target:g} m: no certified answer in "
                               f"{MAX_STEPS} rounds; allowed: another target")
    ev = evidence(run(v_ev), v_ev)
    bound = "feasibility" if not run(hi).feasible else "the accuracy"
    return SpeedChoice(lo, run(lo), f"fastest speed to {tol:g} m/s with sigma_h <= "
                       f"{target:.5g} m: {lo:.4g} m/s (sigma_h {upper_m(run(lo)):.5g} m), "
                       f"{bound} bounds it at {hi:.4g} m/s; " + refutation(ev, target), ev,
                       len(run.plans))


def refutation(ev: Evidence, target_m: float) -> str:
    """Why the speed 1.05 v fails, in words."""
    if not ev.feasible:
        return (f"at {ev.speed_mps:.4g} m/s (P) is proven infeasible (blocking "
                f"{' + '.join(ev.blocking)})")
    return (f"at {ev.speed_mps:.4g} m/s the certified lower bound {ev.lower_bound_m:.5g} m > "
            f"{target_m:.5g} m")


def unreachable(run: Chain, target_m: float, v_min: float, v_max: float) -> str:
    """The one-line error of a target no speed tried meets: the least sigma_h seen."""
    best = min((upper_m(p) for p in run.plans.values() if p.feasible), default=None)
    allowed = (f">= {best:.5g} m (the least certified sigma_h found)" if best is not None
               else "none: (P) is infeasible at every speed tried (blocking "
               + " + ".join(run(v_min).blocking_constraints) + ")")
    return (f"sigma_h_max_m: value {target_m:g} m is met at no speed in {v_min:g}..{v_max:g} "
            f"m/s; allowed: {allowed}")


def slowest_fitting_speed(params: Params, fits: Callable[[float], bool], v_max_mps: float,
                          tol: float = TOL_MPS, *, v_min_mps: float | None = None) -> SpeedChoice:
    """The speed of least sigma_h at which `fits` holds (e.g. the survey fits in N sorties;
    monotone, faster fits more): with sigma_h increasing in v (module docstring), the slowest v
    in [v_min, v_max] with fits(v), by bisection on `fits` to tol. The answer is a speed where
    fits was True; its plan must be feasible, and the plan at 1.05 v is solved to check that
    going faster does not beat it (a certified lower bound there >= its sigma_h)."""
    v_min = check_range(params, v_max_mps, tol, v_min_mps)
    v_max = float(v_max_mps)
    if not fits(v_max):
        raise SpeedSearchError(f"v_max_mps: value {v_max:g} is not allowed; the survey does not "
                               "fit even at it (fits(v_max) is False): a faster airframe or a "
                               "smaller survey")
    lo, v = v_min, v_min if fits(v_min) else v_max
    for _ in range(MAX_STEPS):  # fits(lo) False, fits(v) True
        if v - lo <= tol:
            break
        mid = 0.5 * (lo + v)
        lo, v = (lo, mid) if fits(mid) else (mid, v)
    run = Chain(params)
    plan = run(v)
    if not plan.feasible:
        raise SpeedSearchError(f"fits: the slowest speed that fits, {v:.4g} m/s, has no feasible "
                               f"formation (blocking {' + '.join(plan.blocking_constraints)}); "
                               "allowed: a survey that fits at a speed where (P) is feasible")
    v_ev = min(EVIDENCE_FACTOR * v, SPEED_SPEC.hi)
    ev = evidence(run(v_ev), v_ev)
    if ev.feasible and ev.sigma_h_m < lower_m(plan):
        raise SpeedSearchError(f"fits: sigma_h falls with speed at {v:.4g} m/s ({ev.sigma_h_m:.5g}"
                               f" m at {v_ev:.4g} m/s < {lower_m(plan):.5g} m): the slowest "
                               "fitting speed is not the most accurate; use speed_front")
    proof = ("(P) infeasible" if not ev.feasible else
             f"lower bound {ev.lower_bound_m:.5g} m" + (" >= " if ev.lower_bound_m >=
                                                         upper_m(plan) else " < ") + "it")
    return SpeedChoice(v, plan, f"slowest speed that fits, to {tol:g} m/s: {v:.4g} m/s "
                       f"(sigma_h {upper_m(plan):.5g} m); at {v_ev:.4g} m/s {proof}", ev,
                       len(run.plans))


def speed_front(params: Params, speeds: Sequence[float], *, warm: bool = True
                ) -> list[FrontPoint]:
    """The certified optimum at each speed, in the given order, warm-started from the one
    before (`warm=False`: each solved cold): the accuracy-time front's points."""
    run = Chain(params, warm)
    points = []
    for v in speeds:
        start = time.perf_counter()
        plan = run(v)
        points.append(FrontPoint(float(v), plan.feasible,
                                 upper_m(plan) if plan.feasible else float("nan"),
                                 lower_m(plan), gap(plan),
                                 tuple(plan.blocking_constraints), time.perf_counter() - start))
    return points
