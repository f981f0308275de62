"""One pass's clock: when the along-track target leaves (or resumes at) its point, and where
it is at any instant. The planner, the bridges and the agents all keep the pass in this one
value, and decide "the same start" by its one rule.

A pass starts at `start_s` with its target `offset_m` past the start line (slot 0's): less
than 0 for a pass from the hover, whose run-in lies before the line (track/passes.py), more
for a pass resumed mid-track; the targets hold there until `start_s`. From then on the
target runs along track at `speed_mps`:

    s(t) = offset                                              t < start
    s(t) = offset + a (t - start)^2 / 2                        ramping up, `ramp` only
    s(t) = b(t - start - shift + offset / v)                   then

with a = speed_profile.RAMP_MPS2, shift = v / (2 a) when ramped up from a hover (else 0), and
b the braked cruise of a pass `duration_s` long (speed_profile.braked_pass; 0: endless). A
start heard before its instant (or within JOIN_GRACE_S after it, radio latency) ramps up from
the hover; one heard later joins a running pass at v_y (`heard`). `time_at(d)` is the inverse:
when the target is d past the start line; before the resume point it is the time the same
pass, flown from the line, would have been there.

`start_s` is on the clock of whoever holds the value: wall clock on the wire
(`formation/start`, time.time()) and at the agents, monotonic at a bridge (`shifted` by the
difference of its two clocks, read once). Two starts are the same (a repeat, or a re-plan
under another identity) when their instants agree within SAME_START_S and their offsets
within SAME_LINE_M (`same_start`); two plans fly the same pass when their start lines agree
within SAME_LINE_M (`same_line`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from uav_insar_planner.track.speed_profile import (
    RAMP_MPS2,
    braked_pass,
    braked_time_s,
    ramp_delay_s,
    ramp_up,
)

# Compared as the planner sent them, never as a clock converted at arrival: a thread delayed
# between its two clock reads (a busy computer) moves that by milliseconds. Bridges report
# the instant they fly to 1 ms on /diagnostics (rounded: 0.5 ms), inside this.
SAME_START_S = 2e-3
SAME_LINE_M = 1e-3  # the offset goes on the wire to the millimetre
# A start heard this long after its instant is still a start from the hover (radio latency);
# later, the vehicle joins a running pass: no ramp.
JOIN_GRACE_S = 0.5


def same_line(y_a: float, y_b: float) -> bool:
    """Whether two start lines (along-track y, metres) are the same pass's."""
    return abs(y_a - y_b) < SAME_LINE_M


def same_instant(a_s: float, b_s: float) -> bool:
    """Whether two start instants (seconds, one clock) are the same start's."""
    return abs(a_s - b_s) < SAME_START_S


@dataclass(frozen=True)
class PassClock:
    """See the module docstring. SI: seconds, metres, m/s."""

    start_s: float
    speed_mps: float
    offset_m: float = 0.0
    duration_s: float = 0.0
    ramp: bool = True

    @classmethod
    def heard(cls, start_s: float, now_s: float, speed_mps: float, offset_m: float = 0.0,
              duration_s: float = 0.0) -> PassClock:
        """A start at `start_s` heard at `now_s` (one clock): from the hover (ramped up) unless
        it is more than JOIN_GRACE_S old, then a running pass is joined."""
        return cls(start_s, speed_mps, offset_m, duration_s, start_s >= now_s - JOIN_GRACE_S)

    def same_start(self, other: PassClock | None) -> bool:
        """Whether `other` is this start again (module docstring)."""
        return (other is not None and same_instant(self.start_s, other.start_s)
                and abs(self.offset_m - other.offset_m) < SAME_LINE_M)

    def shifted(self, dt_s: float) -> PassClock:
        """The same pass `dt_s` later; with a clock difference, the same pass on another
        clock."""
        return replace(self, start_s=self.start_s + dt_s)

    @property
    def _t_offset(self) -> float:
        return self.offset_m / self.speed_mps if self.speed_mps > 0.0 else 0.0

    def along(self, t: float) -> tuple[float, float]:
        """(distance past the start line, along-track speed) of the target at `t`."""
        v, hold = self.speed_mps, braked_pass(self._t_offset, self.speed_mps, self.duration_s)
        if t < self.start_s:  # (a resumed pass holds at its offset until its instant)
            return hold[0], 0.0
        elapsed = t - self.start_s
        if self.ramp:
            ramped, speed, shift = ramp_up(elapsed, v)
            if not shift:  # still accelerating
                return hold[0] + ramped, speed
            elapsed -= shift
        return braked_pass(elapsed + self._t_offset, v, self.duration_s)

    def time_at(self, distance_m: float) -> float:
        """When the target is `distance_m` past the start line (module docstring; inf when it
        never gets there)."""
        v = self.speed_mps
        if v <= 0.0:
            return self.start_s if distance_m <= self.offset_m else math.inf
        if self.ramp and distance_m >= self.offset_m:
            u = distance_m - self.offset_m
            if u <= v * v / (2.0 * RAMP_MPS2):  # still accelerating
                return self.start_s + math.sqrt(2.0 * u / RAMP_MPS2)
            shift = ramp_delay_s(v)
        else:
            shift = 0.0
        return (self.start_s + shift + braked_time_s(distance_m, v, self.duration_s)
                - self._t_offset)

    def origin_s(self) -> float:
        """When the target was, or would have been, at the start line: the instant the pass
        counts its slots from."""
        return self.time_at(0.0)

    def target(self, start: tuple[float, float, float], t: float
               ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(position, velocity) at `t` of the UAV whose start point is `start` (x, y, z)."""
        x, y, z = start
        s, speed = self.along(t)
        return (x, y + s, z), (0.0, speed, 0.0)

    def describe(self, now_s: float) -> str:
        """The start told (this value as sent, wall clock; `now_s` time.time()): "in 2.00 s,
        wall clock 1796000012.000, resuming 20.00 m past the start line"."""
        ahead = self.start_s - now_s
        when = f"in {ahead:.2f} s" if ahead >= 0 else f"{-ahead:.2f} s ago (joining the pass)"
        where = (f", resuming {self.offset_m:.2f} m past the start line" if self.offset_m > 0.0
                 else f", from its run-in {-self.offset_m:.2f} m before the start line"
                 if self.offset_m < 0.0 else "")
        return f"{when}, wall clock {self.start_s:.3f}{where}"
