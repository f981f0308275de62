"""The ordered passes of a mission and the transits between them, on one time line.

A pass is a straight line of the master's track in the track frame: slot 0's line at
(x_m, y_start_m), the imaged part `length_m` long along +y (`direction` +1) or -y (-1), and
before it a run-in of `run_in_m` on the same line. Its clock (`TrackPass.clock`) is a
`pass_clock.PassClock` whose resume point lies `run_in_m` before the start line: the target
holds at the run-in's entry until the pass starts, ramps up from the hover there, and crosses
slot 0's line already at v_y when

    run_in_m >= v_y^2 / (2 speed_profile.RAMP_MPS2)                     (`min_run_in_m`)

and brakes only past the imaged part, stopping v_y^2 / (2 speed_profile.BRAKE_MPS2) beyond
it (its run-out). So every slot, the first and the last included, is flown at v_y.
Distances along a pass count in its own direction (s >= 0 forward), so a pass flown the
other way has the same clock.

Between two passes the formation transits in a straight line from where one stopped
(`stop`) to the next one's entry, at the transit speed (its accelerations are left out:
seconds against the minutes a transit takes). `MissionPasses.schedule` lays the passes'
clocks end to end: pass i + 1 starts once pass i has stopped and the transit is flown.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_planner.track.speed_profile import BRAKE_MPS2, RAMP_MPS2

XY = tuple[float, float]


# Beyond the ramp's v^2 / (2 a): the capture radius (1 m by default: a UAV captured that far
# ahead of its entry), a metre to spare, and 6 m of cruise in which the ramp's transient
# settles before slot 0: PX4 (SIH) swings up to 0.6 m across track while it accelerates and
# takes some 6 m at 4.3 m/s to come back within 0.15 m (test_sitl_px4.py).
RUN_IN_MARGIN_M = 8.0


def min_run_in_m(speed_mps: float) -> float:
    """The shortest run-in from a hover that reaches `speed_mps` by slot 0's line [m]."""
    return speed_mps * speed_mps / (2.0 * RAMP_MPS2)


def run_in_m(speed_mps: float) -> float:
    """The run-in every pass from a hover flies before slot 0's line [m]: `min_run_in_m` and
    RUN_IN_MARGIN_M."""
    return min_run_in_m(speed_mps) + RUN_IN_MARGIN_M if speed_mps > 0.0 else 0.0


def run_out_m(speed_mps: float) -> float:
    """How far past the imaged part the target brakes to a stop [m]."""
    return speed_mps * speed_mps / (2.0 * BRAKE_MPS2)


@dataclass(frozen=True)
class TrackPass:
    """One pass (module docstring). SI: metres."""

    x_m: float
    y_start_m: float
    length_m: float
    direction: int = 1
    run_in_m: float = 0.0

    def __post_init__(self) -> None:
        if self.direction not in (1, -1):
            raise ValueError(f"direction: value {self.direction!r} is not allowed; expected 1 "
                             "(along +y) or -1 (along -y)")
        for name in ("length_m", "run_in_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name}: value {value!r} is not allowed; expected a finite "
                                 "distance >= 0 m")

    def point(self, s: float) -> XY:
        """The point `s` metres along the pass from slot 0's line (negative: the run-in)."""
        return self.x_m, self.y_start_m + self.direction * s

    @property
    def entry(self) -> XY:
        """Where the pass begins: the start of its run-in."""
        return self.point(-self.run_in_m)

    def stop(self, speed_mps: float) -> XY:
        """Where the target stops, its run-out past the imaged part flown at `speed_mps`."""
        return self.point(self.length_m + run_out_m(speed_mps))

    def clock(self, start_s: float, speed_mps: float) -> PassClock:
        """The pass flown at `speed_mps` (> 0) from a hover at its entry, from `start_s`."""
        duration = (self.length_m + run_out_m(speed_mps)) / speed_mps
        return PassClock(start_s, speed_mps, -self.run_in_m, duration, ramp=True)

    def stop_s(self, clock: PassClock) -> float:
        """When the target of this pass's `clock` has stopped."""
        return clock.time_at(self.length_m + run_out_m(clock.speed_mps))


@dataclass(frozen=True)
class Transit:
    """The straight flight between two passes, from where one stopped to the next one's
    entry."""

    start: XY
    end: XY
    transit_mps: float

    @property
    def length_m(self) -> float:
        return math.dist(self.start, self.end)

    @property
    def duration_s(self) -> float:
        return self.length_m / self.transit_mps


@dataclass(frozen=True)
class MissionPasses:
    """A mission's passes in flight order, flown at `speed_mps` (v_y), with transits between
    them at `transit_mps`."""

    passes: tuple[TrackPass, ...]
    speed_mps: float
    transit_mps: float

    def __post_init__(self) -> None:
        if not self.passes:
            raise ValueError("passes: value () is not allowed; expected at least one pass")
        for name in ("speed_mps", "transit_mps"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name}: value {value!r} is not allowed; expected a finite "
                                 "speed > 0 m/s")

    def transits(self) -> list[Transit]:
        """The transit after each pass but the last."""
        return [Transit(a.stop(self.speed_mps), b.entry, self.transit_mps)
                for a, b in zip(self.passes, self.passes[1:], strict=False)]

    def schedule(self, start_s: float) -> list[PassClock]:
        """Each pass's clock, the first starting at `start_s`, each next one when the one
        before has stopped and the transit between them is flown."""
        clocks = [self.passes[0].clock(start_s, self.speed_mps)]
        for previous, transit, following in zip(self.passes, self.transits(), self.passes[1:],
                                                strict=False):
            begin = previous.stop_s(clocks[-1]) + transit.duration_s
            clocks.append(following.clock(begin, self.speed_mps))
        return clocks

    def duration_s(self) -> float:
        """From the first pass's start to the last one's stop."""
        return self.passes[-1].stop_s(self.schedule(0.0)[-1])
