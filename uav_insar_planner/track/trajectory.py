"""The pass every UAV flies in the track frame: the formation on one pass clock.

UAV k's target is its entry (x_k, y_start - run_in, z_k) until the pass has a clock, then
(x_k, y_start + s(t), z_k) with s the clock's (`pass_clock.PassClock.along`). The run-in
(`passes.run_in_m`) lies before the start line (slot 0's), so that a pass from the hover at
the entry crosses the line at v_y: every slot is flown at the planned speed. A new formation
with the same start line keeps the clock running (a re-plan during the pass); one with another
start line is another pass, whose clock is yet to come.

The clock comes from the bridge's own capture at the entries (`start_now`, the clock's
resume point run_in before the line) or from the planner's start
(`start_from`): that one is kept as it was sent (`sent`, wall clock), to be compared with the
next one, and on the reader's monotonic clock (`clock`), to fly.
"""
from __future__ import annotations

from uav_insar_planner.plan import Vec3
from uav_insar_planner.track.pass_clock import PassClock, same_line
from uav_insar_planner.track.passes import run_in_m


class PassTrajectory:
    """The formation and its pass clock. Not thread-safe (the bridge holds its lock)."""

    def __init__(self, speed_mps: float, duration_s: float):
        self.speed_mps, self.duration_s = speed_mps, duration_s
        self.run_in_m = run_in_m(speed_mps)
        self.formation: list[Vec3 | None] | None = None
        self.clock: PassClock | None = None  # on this reader's clock; None: not started
        self.sent: PassClock | None = None  # the planner's start it came from, as sent

    def set_formation(self, clean: list[Vec3 | None]) -> bool:
        """Adopt a cleaned formation; True when it restarts a running pass (new y_start)."""
        old = self.formation
        same = old is not None and all(a is None or b is None or same_line(a[1], b[1])
                                       for a, b in zip(old, clean, strict=True))
        self.formation = clean
        if not same and self.clock is not None:
            self.clock = self.sent = None
            return True
        return False

    def start_now(self, now: float) -> None:
        """The pass starts from the hover at the entries at `now` (the bridge's own capture)."""
        self.clock = PassClock(now, self.speed_mps, -self.run_in_m, self.duration_s)
        self.sent = None

    def start_from(self, start_s: float, offset_m: float, now: float, wall_now: float
                   ) -> PassClock | None:
        """The planner's start at `start_s` (wall clock), `offset_m` past the start line, heard
        at monotonic `now` = wall clock `wall_now`: the clock as sent, now flown; None when it
        is the start flown already."""
        sent = PassClock.heard(start_s, wall_now, self.speed_mps, offset_m, self.duration_s)
        if sent.same_start(self.sent) and self.clock is not None:
            return None
        self.sent, self.clock = sent, sent.shifted(now - wall_now)
        return sent

    def running(self, now: float) -> bool:
        """Whether the pass has started by `now` (its targets move, or did)."""
        return self.clock is not None and now >= self.clock.start_s

    def start_pose(self, uav: int) -> Vec3 | None:
        """UAV `uav`'s start point (x_k, y_start, z_k), None if it is not flown."""
        return None if self.formation is None else self.formation[uav]

    def entry(self, uav: int) -> Vec3 | None:
        """Where UAV `uav` waits for the pass from the hover: its run-in's start, or None."""
        start = self.start_pose(uav)
        return None if start is None else (start[0], start[1] - self.run_in_m, start[2])

    def target(self, uav: int, now: float) -> tuple[Vec3, Vec3] | None:
        """(position, velocity) of UAV `uav` in the track frame at `now`, or None."""
        start = self.start_pose(uav)
        if start is None:
            return None
        if self.clock is None:
            return self.entry(uav), (0.0, 0.0, 0.0)
        return self.clock.target(start, now)
