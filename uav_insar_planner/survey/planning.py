"""A whole survey planned: the speed, one certified formation, the strips, each strip's power
schedule, the sorties and the coverage (`plan_survey` -> `SurveyPlan`).

1. The speed: given, or chosen with a certificate (survey/speed.py): the fastest whose
   certified optimum keeps sigma_h <= `sigma_h_max_m`, or the slowest (least sigma_h) whose
   survey fits in `sorties` sorties. The scenario's certified plan at that speed gives the
   formation every strip flies.
2. Its master fixes the geometry: the swath S_0 = Theta_3dB r_0 / cos(theta_0) (C5's, the
   plan's metrics) centred z_0 tan(theta_0) = x_t - x_0 (C2) to the right of the master's track.
   Each strip's run-in is every pass's (track.passes.run_in_m): v_y^2 / (2 RAMP_MPS2) and a
   margin, so that slot 0's line is crossed at v_y.
3. The strips (survey/strips.py) on the given bearing or on the one with the least flight time
   (`best_bearing` over the sorties' time), each imaged part lengthened to whole slots.
4. Each strip's offloading: the strip's own slot count, and the ground station where it stands
   in that strip's formation frame. Only C9-C11 read them (C1-C8 are the formation's, certified
   once). For the shared formation the cheapest schedule meeting C10 is the strip's plan, and
   C9 and C11 hold for it iff each UAV's x-z distance to the station lies within the station
   disk (solver/power.py: exact, not a relaxation, each family's own disk naming the one that
   fails); a strip the station cannot serve is refused by name: move the station
   (`station_ne_m`) or shorten the strips (the area, the bearing).
5. The sorties (survey/sorties.py) and the brute-force coverage (survey/coverage.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from uav_insar_planner.params import Params
from uav_insar_planner.plan import Plan
from uav_insar_planner.solver import solve
from uav_insar_planner.solver.power import schedules, station_radius_sq
from uav_insar_planner.survey.area import Area
from uav_insar_planner.survey.coverage import cell_size_m, covered_fraction
from uav_insar_planner.survey.sorties import FlightSpeeds, Sortie, plan_sorties
from uav_insar_planner.survey.speed import fastest_speed, slowest_fitting_speed, speed_front
from uav_insar_planner.survey.strips import Strip, best_bearing, layout_strips
from uav_insar_planner.track.passes import run_in_m

AIRFRAME_MAX_MPS = 15.0  # a survey multicopter's top ground speed with a radar payload


class SurveyInfeasible(ValueError):
    """No survey: the scenario has no plan at the speed, or a strip the station cannot serve
    (one line, naming what blocks)."""


@dataclass(frozen=True)
class SurveyOptions:
    """What the user asks (SI): overlap between adjacent swaths; bearing (None: the least
    flight time); battery endurance and reserve; speed (None: chosen, by `sigma_h_max_m` or
    `sorties`); the airframe's top speed; the sorties' flight speeds; the ground station's
    (north, east) about the home (its height is the scenario's g_z)."""

    overlap: float = 0.2
    bearing_rad: float | None = None
    endurance_s: float = 20.0 * 60.0
    reserve: float = 0.2
    speed_mps: float | None = None
    sigma_h_max_m: float | None = None
    sorties: int | None = None
    max_speed_mps: float = AIRFRAME_MAX_MPS
    fly: FlightSpeeds = field(default_factory=FlightSpeeds)
    station_ne_m: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        checks = (("overlap", self.overlap, 0.0 <= self.overlap < 1.0, "a fraction in [0, 1)"),
                  ("endurance_min", self.endurance_s / 60.0, self.endurance_s > 0.0,
                   "a finite time > 0 min"),
                  ("reserve", self.reserve, 0.0 <= self.reserve < 1.0, "a fraction in [0, 1)"),
                  ("max_speed", self.max_speed_mps, self.max_speed_mps > 0.0,
                   "a finite speed > 0 m/s"))
        for name, value, ok, expected in checks:
            if not (math.isfinite(value) and ok):
                raise ValueError(f"{name}: value {value!r} is not allowed; expected {expected}")
        if self.speed_mps is None and (self.sigma_h_max_m is None) == (self.sorties is None):
            raise ValueError("speed: value 'auto' is not allowed alone; expected it with one of "
                             "sigma_h_max (the fastest speed meeting it) or sorties (the least "
                             "sigma_h within that many sorties)")

    @property
    def budget_s(self) -> float:
        """A sortie's flight time at most: endurance x (1 - reserve)."""
        return self.endurance_s * (1.0 - self.reserve)


@dataclass(frozen=True)
class StripPlan:
    """One strip as flown: its slot count, the station in its formation frame (x, y, z) and
    the power schedule P_com[k][n] [W] of the shared formation there."""

    strip: Strip
    num_slots: int
    station_m: tuple[float, float, float]
    p_com_w: np.ndarray


@dataclass(frozen=True)
class SurveyPlan:
    """The survey (module docstring): `plan` is the certified plan of the formation every
    strip flies, at `speed_mps`."""

    area: Area
    options: SurveyOptions
    speed_mps: float
    speed_why: str
    plan: Plan
    bearing_rad: float
    run_in_m: float
    strips: tuple[StripPlan, ...]
    sorties: tuple[Sortie, ...]
    covered_fraction: float

    @property
    def swath_m(self) -> float:
        return self.strips[0].strip.swath_m

    @property
    def total_time_s(self) -> float:
        """The sorties' flight time, battery changes left out."""
        return sum(s.flight_time_s for s in self.sorties)


def geometry(params: Params, plan: Plan) -> tuple[float, float, float]:
    """(S_0, z_0 tan theta_0, the highest UAV's height) of `plan`'s formation [m]."""
    x0 = float(plan.formation[0, 0])
    flown = plan.formation[np.all(np.isfinite(plan.formation), axis=1)]
    return (float(plan.metrics["swath_m"]["uav0"]), params.x_t - x0,
            float(flown[:, 1].max()))


def _layout(area: Area, params: Params, plan: Plan, options: SurveyOptions
            ) -> tuple[float, list[Strip], list[Sortie]]:
    """(bearing, strips with whole slots, sorties) at the plan's speed."""
    swath, offset, height = geometry(params, plan)
    run_in = run_in_m(params.speed)
    slot_m = params.speed * params.slot_duration_s

    def strips_at(bearing: float) -> list[Strip]:
        laid = layout_strips(area, bearing, swath, offset, options.overlap, run_in)
        return [replace(s, track=replace(s.track, length_m=slot_m * max(1, math.ceil(
            s.track.length_m / slot_m - 1e-9)))) for s in laid]

    def flight_time(bearing: float) -> float:
        sorties = _sorties(strips_at(bearing), height, params.speed, options, strict=False)
        return math.inf if sorties is None else sum(s.flight_time_s for s in sorties)

    bearing = (options.bearing_rad if options.bearing_rad is not None
               else best_bearing(area, flight_time))
    strips = strips_at(bearing)
    return bearing, strips, _sorties(strips, height, params.speed, options)


def _sorties(strips: list[Strip], height: float, speed: float, options: SurveyOptions,
             strict: bool = True) -> list[Sortie] | None:
    try:
        return plan_sorties([s.track for s in strips], height, speed, options.budget_s,
                            options.fly)
    except ValueError:
        if strict:
            raise
        return None


def strip_plan(params: Params, plan: Plan, strip: Strip, station_ne: tuple[float, float]
               ) -> tuple[StripPlan, list[str]]:
    """The strip's slot count, station and power schedule for the shared formation, and the
    constraints it violates there (empty: feasible)."""
    n = max(1, round(strip.track.length_m / (params.speed * params.slot_duration_s)))
    frame = strip.frame(float(plan.formation[0, 0]))
    gx, gy, _ = frame.from_ned(station_ne[0], station_ne[1], 0.0)
    station = (gx, gy, params.ground_station[2])
    local = params.replace(num_slots=n, ground_station_m=list(station))
    violated = set()
    for k, (x, z) in enumerate(plan.formation):
        rho2 = (x - station[0]) ** 2 + (z - station[2]) ** 2
        if np.isfinite(rho2) and rho2 > station_radius_sq(local, k, plan.scheme):
            violated |= {c for c, other in (("C9", "C11"), ("C11", "C9"))
                         if rho2 > station_radius_sq(local, k, plan.scheme, frozenset({other}))}
    power = schedules(local, plan.formation, plan.scheme)
    return StripPlan(strip, n, station, power), sorted(violated)


def choose_speed(params: Params, area: Area, options: SurveyOptions
                 ) -> tuple[Plan, float, str]:
    """(the certified plan at the survey's speed, that speed, why it) (module docstring)."""
    if options.speed_mps is not None:
        plan = solve(params.replace(speed_mps=options.speed_mps))
        if not plan.feasible:
            raise SurveyInfeasible(f"speed: value {options.speed_mps:g} m/s is not allowed; "
                                   "the scenario has no plan there, blocked by "
                                   + ", ".join(plan.blocking_constraints))
        return plan, options.speed_mps, "given"
    if options.sigma_h_max_m is not None:
        choice = fastest_speed(params, options.sigma_h_max_m, options.max_speed_mps)
        return choice.plan, choice.speed_mps, choice.why

    def fits(v: float) -> bool:
        at = solve(params.replace(speed_mps=v))
        if not at.feasible:
            return False
        try:
            return len(_layout(area, at_params(params, v), at, options)[2]) <= options.sorties
        except ValueError:
            return False

    choice = slowest_fitting_speed(params, fits, options.max_speed_mps)
    return choice.plan, choice.speed_mps, choice.why


def at_params(params: Params, speed_mps: float) -> Params:
    """The scenario at `speed_mps`."""
    return params if speed_mps == params.speed else params.replace(speed_mps=speed_mps)


def plan_survey(area: Area, params: Params, options: SurveyOptions) -> SurveyPlan:
    """The survey of `area` under the scenario `params` (module docstring); ValueError (one
    line) for what cannot be flown."""
    plan, speed, why = choose_speed(params, area, options)
    local = at_params(params, speed)
    bearing, strips, sorties = _layout(area, local, plan, options)
    planned, blocked = [], []
    for strip in strips:
        sp, violated = strip_plan(local, plan, strip, options.station_ne_m)
        planned.append(sp)
        if violated:
            blocked.append(f"strip {strip.index} ({', '.join(violated)})")
    if blocked:
        raise SurveyInfeasible(
            f"station: the ground station at {options.station_ne_m[0]:.0f} m north, "
            f"{options.station_ne_m[1]:.0f} m east of the home cannot serve "
            f"{'; '.join(blocked[:5])}{' ...' if len(blocked) > 5 else ''}; expected a "
            "station nearer the strips (or shorter strips: the area, the bearing)")
    cell = cell_size_m(area)
    return SurveyPlan(area, options, speed, why, plan, bearing,
                      run_in_m(speed), tuple(planned), tuple(sorties),
                      covered_fraction(area, strips, geometry(local, plan)[0], cell))


@dataclass(frozen=True)
class FrontRow:
    """One point of the accuracy-time front: v_y, the certified sigma_h and lower bound, and
    the survey's flight time there (nan where no plan, or the survey does not fit)."""

    speed_mps: float
    sigma_h_m: float
    lower_bound_m: float
    total_time_s: float


def accuracy_time_front(area: Area, params: Params, options: SurveyOptions,
                        speeds: list[float]) -> list[FrontRow]:
    """The certified front at `speeds` (survey/speed.py), each with the survey's time."""
    rows = []
    for point in speed_front(params, speeds):
        time_s = math.nan
        if point.feasible:
            local = at_params(params, point.speed_mps)
            try:
                sorties = _layout(area, local, solve(local), options)[2]
                time_s = sum(s.flight_time_s for s in sorties)
            except ValueError:
                pass
        rows.append(FrontRow(point.speed_mps, point.sigma_h_m, point.lower_bound_m, time_s))
    return rows
