"""A survey's strips grouped, in flight order, into sorties that fit a battery.

A sortie is one flight from take-off at home to landing there:

    climb      max_k z_k / climb_mps                  (the formation climbs over home)
    transit    home -> the first strip's entry         at transit_mps
    strips     each: a settle of `settle_s` at its entry (the capture and the start's
               delay), then its run-in, imaged part and run-out on its pass clock, and the
               turn to the next one (track.passes.MissionPasses, transits at transit_mps)
    return     the last strip's stop -> home           at transit_mps
    descent    max_k z_k / descent_mps

Distances are the master's ground track in the survey frame (home at the origin); the slaves
fly beside it, a few tens of metres off, which the reserve covers. Strips are added to the
sortie in flight order while its flight time stays within endurance x (1 - reserve); a strip
that does not fit even alone is refused, naming it and the time it needs.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from uav_insar_planner.track.passes import MissionPasses, TrackPass

# Below the autopilots' defaults (ArduCopter: 2.5 m/s up, 1.5 m/s down, 10 m/s across; PX4:
# 3, 1, 5 m/s), so the times are ones a vehicle keeps in wind.
CLIMB_MPS = 2.0
DESCENT_MPS = 1.0
TRANSIT_MPS = 5.0
# At each strip's entry: the formation captured (a copter settles in a few seconds) and the
# planner's start delay (start_delay_s, 2 s).
SETTLE_S = 8.0


@dataclass(frozen=True)
class FlightSpeeds:
    """How a sortie flies outside its strips (SI): climb, descent, transit; the settle at each
    strip's entry."""

    climb_mps: float = CLIMB_MPS
    descent_mps: float = DESCENT_MPS
    transit_mps: float = TRANSIT_MPS
    settle_s: float = SETTLE_S

    def __post_init__(self) -> None:
        for name in ("climb_mps", "descent_mps", "transit_mps"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name}: value {value!r} is not allowed; expected a finite "
                                 "speed > 0 m/s")
        if not (math.isfinite(self.settle_s) and self.settle_s >= 0.0):
            raise ValueError(f"settle_s: value {self.settle_s!r} is not allowed; expected a "
                             "finite time >= 0 s")


@dataclass(frozen=True)
class Sortie:
    """One flight: the indices of its strips (in the survey's strip order) and its legs [s]."""

    strips: tuple[int, ...]
    climb_s: float
    transit_s: float
    strips_s: float
    return_s: float
    descent_s: float

    @property
    def flight_time_s(self) -> float:
        return self.climb_s + self.transit_s + self.strips_s + self.return_s + self.descent_s


HOME = (0.0, 0.0)


def pass_s(strip: TrackPass, speed_mps: float) -> float:
    """A strip's pass from the hover at its entry to its stop [s] (its clock's)."""
    return strip.stop_s(strip.clock(0.0, speed_mps))


def sortie_of(strips: Sequence[TrackPass], indices: Sequence[int], height_m: float,
              speed_mps: float, fly: FlightSpeeds) -> Sortie:
    """The sortie flying strips[i] for i in `indices`, in that order, at `height_m` (the
    highest UAV's) and v_y `speed_mps`: the passes' clocks laid end to end with the turns
    between them (track.passes.MissionPasses.duration_s), and a settle at each entry."""
    chosen = [strips[i] for i in indices]
    turns = sum(math.dist(a.stop(speed_mps), b.entry)
                for a, b in zip(chosen, chosen[1:], strict=False)) / fly.transit_mps
    return Sortie(
        strips=tuple(indices), climb_s=height_m / fly.climb_mps,
        transit_s=math.dist(HOME, chosen[0].entry) / fly.transit_mps,
        strips_s=sum(pass_s(s, speed_mps) + fly.settle_s for s in chosen) + turns,
        return_s=math.dist(chosen[-1].stop(speed_mps), HOME) / fly.transit_mps,
        descent_s=height_m / fly.descent_mps)


def plan_sorties(strips: Sequence[TrackPass], height_m: float, speed_mps: float,
                 budget_s: float, fly: FlightSpeeds = FlightSpeeds()) -> list[Sortie]:
    """`strips` (survey frame, home at the origin, in flight order) in sorties of at most
    `budget_s` each (module docstring); ValueError (one line) when one strip alone does not
    fit. Each strip is tried once: the sortie's time grows by its turn, settle and pass, and
    its return is from the new last strip."""
    climb, descent = height_m / fly.climb_mps, height_m / fly.descent_mps
    sorties: list[Sortie] = []
    current: list[int] = []
    spent = 0.0  # the current sortie's climb, transit out, passes, settles and turns
    for i, strip in enumerate(strips):
        stop = strip.stop(speed_mps)
        flying = pass_s(strip, speed_mps) + fly.settle_s
        back = math.dist(stop, HOME) / fly.transit_mps
        if current:
            turn = math.dist(strips[current[-1]].stop(speed_mps), strip.entry) / fly.transit_mps
            if spent + turn + flying + back + descent <= budget_s:
                current.append(i)
                spent += turn + flying
                continue
            sorties.append(sortie_of(strips, current, height_m, speed_mps, fly))
        spent = climb + math.dist(HOME, strip.entry) / fly.transit_mps + flying
        if spent + back + descent > budget_s:
            alone = sortie_of(strips, [i], height_m, speed_mps, fly)
            raise ValueError(
                f"endurance_min: value {budget_s / 60.0:.3g} min of flight (after the "
                f"reserve) is not allowed; expected at least {alone.flight_time_s / 60.0:.3g} "
                f"min, what strip {i} alone takes (climb, transit, strip, return, descent)")
        current = [i]
    if current:
        sorties.append(sortie_of(strips, current, height_m, speed_mps, fly))
    return sorties


def strip_starts_s(strips: Sequence[TrackPass], sortie: Sortie, speed_mps: float,
                   fly: FlightSpeeds = FlightSpeeds()) -> list[float]:
    """When each strip of `sortie` starts its pass, in seconds from take-off: after the climb,
    the transit, and a settle at each entry (the passes' clocks laid end to end)."""
    chosen = tuple(strips[i] for i in sortie.strips)
    clocks = MissionPasses(chosen, speed_mps, fly.transit_mps).schedule(0.0)
    return [sortie.climb_s + sortie.transit_s + (j + 1) * fly.settle_s + c.start_s
            for j, c in enumerate(clocks)]
