"""Position source for a UAV that something else flies (a MAVLink vehicle under the bridge).

The agent only watches: it is given the UAV's actual position and when it was read
(`observe`), and applies the schedule where the plan puts it. The pass runs on one mission
clock, the planner's pass start (`formation/start`, wall clock: a
`track.pass_clock.PassClock`, `set_pass_start`), which is also when every bridge sets its
vehicle moving along the track. Before that instant no slot starts, whatever the UAV does:
it may climb, cross the track on its way to its formation point, or hold that point
jittering about the slot 0 line. From that instant on, slot n starts at the first position
at or past its line y = y_start + n v_y delta_t (`SlotSchedule.slot_line`): interpolated
onto the line when the observation before was behind it, else where the UAV is (it held just
ahead of the line). So the slots follow the vehicle's real progress whatever its clock or
speed, and wherever it took off. The mission is `done` once the line after the last slot is
reached.

A pass start that arrives late (a lossy radio repairs a lost sample only seconds later)
finds the UAV already on its way: the positions read since the start (kept for HISTORY_S)
are replayed, so each slot still starts where the UAV crossed its line, only reported late.

`lag` tells how far the UAV is behind the mission clock: the pass start passed, its next
line not reached while the clock says it should have been, for the agent to say so.

A slot is flown at the planned speed when the time from its line to the next (`durations`)
is within SPEED_TOLERANCE of the plan's (or OFF_SPEED_MIN_S, for the position noise):
delta_t at v_y, longer where the bridge's target ramps up from the hover (`line_time`: the
pass clock's `time_at`, as the bridge flies it); one flown slower (a hold in it) or faster
(a catch-up) is `off_speed`, and the agent says so and does not count it as flown at the
planned speed.
"""
from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence

from uav_insar_planner.params import Params
from uav_insar_planner.plan import Vec3
from uav_insar_planner.track.pass_clock import PassClock, same_line
from uav_insar_sim.fading import LinkFading
from uav_insar_sim.offload import ClosedLoopOffload
from uav_insar_sim.slots import Phase, SlotSample, SlotSchedule

# Positions kept for a pass start that arrives late: longer than any repair of a lost sample.
HISTORY_S = 30.0
# A slot whose line-to-line time is off delta_t by more than this fraction was not flown at
# v_y: its samples are not where the plan put them (the done-when of issue 27: 0.9).
SPEED_TOLERANCE = 0.1
# ... and by at least this much: GNSS noise of 0.3 m moves a crossing by 0.07 s at 4.3 m/s, a
# slot's duration by 0.1 s (two crossings); a hold or a catch-up sprint is far more.
OFF_SPEED_MIN_S = 0.25


class ObservedMission(SlotSchedule):
    """Slots of UAV `uav_id` under `params` (SI), triggered by the observed position once the
    pass has started."""

    def __init__(self, uav_id: int, params: Params, fading: LinkFading | None = None,
                 controller: ClosedLoopOffload | None = None):
        super().__init__(uav_id, params, fading, controller)
        self._last: Vec3 | None = None
        self._last_t: float | None = None
        self.clock: PassClock | None = None  # the pass's, wall clock; None: not (yet) known
        self.slot_times_s: list[float] = []  # wall clock of the observation that started each
        self.end_time_s: float | None = None  # when the line after the last slot was reached
        # each slot's planned duration, fixed when it ends: by the pass clock flown then (a
        # later resumed start changes the clock, not what was planned for the slots before)
        self.planned_s: list[float] = []
        self._history: deque[tuple[float, Vec3]] = deque()  # (read at, position), oldest first

    def actual_position(self) -> Vec3 | None:
        """The last observed position (None before the first)."""
        return self._last

    @property
    def pass_start_s(self) -> float | None:
        """From when slots start (wall clock; None without a start): the pass's instant, when
        its target leaves the run-in's entry, or for a pass resumed mid-track the instant its
        target was, or would have been, at the start line (its slots before the resume point
        were flown then)."""
        return None if self.clock is None else min(self.clock.start_s, self.clock.origin_s())

    def set_plan(self, target_xz: tuple[float, float], powers: Sequence[float],
                 y_start: float = 0.0) -> None:
        if self.target_xz is not None and not same_line(float(y_start), self.y_start):
            self.clock = None  # another pass: the old one's start no longer applies
        super().set_plan(target_xz, powers, y_start)

    def set_pass_start(self, clock: PassClock) -> list[SlotSample]:
        """The pass of the flown plan runs on `clock` (wall clock); the slots that the
        positions read since it started start, when it comes late (module doc)."""
        self.clock = clock
        wall_time_s = clock.origin_s()
        since = [(t, q) for t, q in self._history if t >= wall_time_s]
        if not since:
            return []
        earlier = [(t, q) for t, q in self._history if t < wall_time_s]
        self._last, self._last_t = (earlier[-1][1], earlier[-1][0]) if earlier else (None, None)
        return [sample for t, q in since for sample in self._advance(q, t)]

    def observe(self, position: Sequence[float], wall_time_s: float) -> list[SlotSample]:
        """Record the UAV at `position` (x, y, z), read at `wall_time_s`; return the slots that
        started with it, in order."""
        here = (float(position[0]), float(position[1]), float(position[2]))
        t = float(wall_time_s)
        self._history.append((t, here))
        while self._history and self._history[0][0] < t - HISTORY_S:
            self._history.popleft()
        return self._advance(here, t)

    def _advance(self, here: Vec3, wall_time_s: float) -> list[SlotSample]:
        before, self._last = self._last, here
        before_t, self._last_t = self._last_t, wall_time_s
        started: list[SlotSample] = []
        if (not self.phase.under_way or self.pass_start_s is None
                or wall_time_s < self.pass_start_s):
            return started
        while not self.all_flown:
            line = self.slot_line(len(self.samples))
            if here[1] < line:
                break
            crossed = before is not None and before[1] < line
            started.append(self.start_slot(interpolate(before, here, line) if crossed else here))
            # when it crossed the line, as far as two readings tell (10 Hz: a slot's duration
            # from reading times alone would be off by up to a tenth of a 1 s slot)
            s = (line - before[1]) / (here[1] - before[1]) if crossed else 1.0
            self.slot_times_s.append(wall_time_s if before_t is None or not crossed else
                                     max(before_t + s * (wall_time_s - before_t),
                                         self.pass_start_s))
            self._plan_ended(len(self.slot_times_s) - 2)
        if self.all_flown and here[1] >= self.slot_line(self.num_slots):
            self.phase = Phase.DONE
            line = self.slot_line(self.num_slots)
            crossed = before is not None and before_t is not None and before[1] < line
            self.end_time_s = (before_t + (line - before[1]) / (here[1] - before[1])
                               * (wall_time_s - before_t) if crossed else wall_time_s)
            self._plan_ended(self.num_slots - 1)
        return started

    def _plan_ended(self, n: int) -> None:
        """Slot n just ended: keep its planned duration by the clock flown now."""
        if n >= 0 and len(self.planned_s) == n:
            self.planned_s.append(self.line_time(n + 1) - self.line_time(n))

    def line_time(self, n: int) -> float:
        """When the plan's target crosses slot n's line (wall clock; the pass started)."""
        return self.clock.time_at(self.slot_line(n) - self.y_start)

    def durations(self) -> list[float]:
        """Each slot's time from its line to the next (the last one's to the line after
        it), for the slots whose end was seen."""
        ends = self.slot_times_s[1:] + ([self.end_time_s] if self.end_time_s is not None
                                        and self.all_flown else [])
        return [b - a for a, b in zip(self.slot_times_s, ends, strict=False)]

    def off_speed(self) -> list[tuple[int, float]]:
        """(slot, duration) of every slot flown off the planned speed (module doc)."""
        return [(n, d) for n, (d, planned) in enumerate(zip(self.durations(), self.planned_s,
                                                              strict=False))
                if abs(d - planned) > max(SPEED_TOLERANCE * planned, OFF_SPEED_MIN_S)]

    def lag(self, wall_now_s: float) -> tuple[int, float, float] | None:
        """(next slot n, seconds since the clock put the UAV on its line, metres still to go
        to it) while the pass has started and the UAV has not reached slot n's line by its
        time pass_start + n delta_t; None otherwise (no start yet, on time, done, held)."""
        if (self.pass_start_s is None or not self.phase.under_way
                or self.all_flown):
            return None
        n = len(self.samples)
        late = wall_now_s - self.line_time(n)
        if late <= 0.0:
            return None
        to_go = self.slot_line(n) - self._last[1] if self._last is not None else math.nan
        return n, late, to_go


def interpolate(a: Vec3, b: Vec3, y: float) -> Vec3:
    """The point of segment a-b (a[1] < y <= b[1]) where the along-track coordinate equals y."""
    s = (y - a[1]) / (b[1] - a[1])
    return (a[0] + s * (b[0] - a[0]), y, a[2] + s * (b[2] - a[2]))
