"""One strip of a survey as the swarm flies it: which strip, of which sortie, its track frame
and its length.

A survey (survey/) is flown strip after strip, each a pass in a track frame of its own: y
along the strip's direction of flight, x to its right (where the radar looks), slot 0's line
at y = 0. The frame is given about the survey's home, in the home's local NED (north, east,
down; D = 0 at the home's height), its bearing from north:

    strip frame -> home NED:      TrackFrame(heading, origin_about_home)
    home NED -> a vehicle's NED:  + the home's place in that vehicle's local NED

A vehicle's local NED is north-aligned (the EKF origin frame), so the strip's heading holds
for every vehicle; only the origins differ, by where each vehicle's EKF origin lies (where it
booted, for most autopilots). `placed(home)` is that frame on one vehicle, with `home` the
track frame its bridge or agent was configured with (`origin_ned_m`: the home in the vehicle's
local NED; its bearing serves a single pass and is not used by a strip).

`station_ne_m` is the ground station (north, east about the home; its height is the
scenario's): the agents model each strip's link from it, in the strip's frame (`station`).

`last` marks the sortie's last strip: after it the vehicles return and land. `attempt`
counts the strip's flights (1 the first): a strip interrupted (a UAV lost, a hold) is flown
again as attempt 2, a new pass with slots of its own, never the same one resumed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_planner.track.passes import run_out_m

# A strip is over this long after its target passed the imaged part's end: its braking
# (v / BRAKE_MPS2, 1.3 s at 4 m/s) and the vehicles' lag behind their targets.
SETTLE_S = 3.0
# The cruise goes on this far past the imaged part: a vehicle lags its target by up to a
# metre, and it must cross the last slot's end line at v_y too, not braking.
RUN_PAST_M = 2.0


def over_at(clock: PassClock, length_m: float) -> float:
    """When a strip `length_m` long flown on `clock` is over (its clock's time base): SETTLE_S
    after its target ended its cruise, RUN_PAST_M past the imaged part."""
    return clock.time_at(length_m + RUN_PAST_M) + SETTLE_S


@dataclass(frozen=True)
class SurveyLeg:
    """See the module docstring. `strip` and `sortie` count from 0; SI: metres, radians."""

    strip: int
    sortie: int
    last: bool
    frame: TrackFrame
    length_m: float
    attempt: int = 1
    station_ne_m: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.strip < 0 or self.sortie < 0 or self.attempt < 1:
            raise ValueError(f"strip, sortie, attempt: values {self.strip!r}, {self.sortie!r}, "
                             f"{self.attempt!r} are not allowed; expected indices >= 0 and an "
                             "attempt >= 1")
        if not (math.isfinite(self.length_m) and self.length_m > 0.0):
            raise ValueError(f"length_m: value {self.length_m!r} is not allowed; expected a "
                             "finite strip length > 0 m")
        values = (self.frame.bearing_rad, *self.frame.origin_ned)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"frame: value {values!r} is not allowed; expected a finite "
                             "bearing and origin")

    def placed(self, home: TrackFrame) -> TrackFrame:
        """The strip's frame in the local NED of a vehicle whose configured frame is `home`
        (module docstring)."""
        n, e, d = self.frame.origin_ned
        n0, e0, d0 = home.origin_ned
        return TrackFrame(self.frame.bearing_rad, (n + n0, e + e0, d + d0))

    def duration_s(self, speed_mps: float) -> float:
        """The pass's `duration_s` at `speed_mps` (speed_profile.braked_pass: the target stops
        at v_y times it) [s]: the imaged part and RUN_PAST_M at v_y, then the run-out."""
        return (self.length_m + RUN_PAST_M + run_out_m(speed_mps)) / speed_mps

    def station(self, height_m: float) -> tuple[float, float, float]:
        """The ground station in this strip's frame (x, y, z) at `height_m` above the home;
        ValueError when the leg names none."""
        if self.station_ne_m is None:
            raise ValueError("station_ne_m: value None is not allowed; expected the station")
        x, y, _ = self.frame.from_ned(*self.station_ne_m, 0.0)
        return x, y, height_m

    def over_at(self, clock: PassClock) -> float:
        """When this strip flown on `clock` is over (`over_at`)."""
        return over_at(clock, self.length_m)

    def describe(self) -> str:
        """'strip 3 of sortie 1 (its last)' for a log line (counted from 1, as people do)."""
        return (f"strip {self.strip + 1} of sortie {self.sortie + 1}"
                + (f", attempt {self.attempt}" if self.attempt > 1 else "")
                + (" (its last)" if self.last else ""))
