"""A vehicle that rejoins a running pass from a hover catches up gently, never sprinting.

Its target is not the pass clock's at once (which is ahead of it, and moving at v_y while it
stands): it starts where the vehicle is and ramps up (speed_profile.ramp_up, RAMP_MPS2) to
v_y + CATCH_UP_MPS, until it meets the clock's target; from then on the vehicle flies the
pass. Losing ground while accelerating and winning it back at 1 m/s, a vehicle 1 m behind
is back in about 10 s at Table I's 4.3 m/s.
"""
from __future__ import annotations

from uav_insar_planner.plan import Vec3
from uav_insar_planner.track.speed_profile import ramp_up

CATCH_UP_MPS = 1.0  # issue 27: never faster than the planned speed + 1 m/s
CATCH_UP_FROM_M = 0.3  # closer behind, the position controller closes the gap unaided


class CatchUp:
    """The governed target of one vehicle that rejoined at `t0` standing `y0` metres along
    the track, on a pass flown at `speed_mps`."""

    def __init__(self, t0: float, y0: float, speed_mps: float) -> None:
        self.t0, self.y0, self.cap = t0, y0, speed_mps + CATCH_UP_MPS

    def target(self, clock: tuple[Vec3, Vec3], now: float) -> tuple[Vec3, Vec3] | None:
        """The vehicle's target at `now` given the clock's (`PassTrajectory.target`); None
        once it has caught up (fly the clock's from then on)."""
        (x, y, z), _ = clock
        offset, speed, _ = ramp_up(now - self.t0, self.cap)
        if self.y0 + offset >= y:
            return None
        return (x, self.y0 + offset, z), (0.0, speed, 0.0)


def governed(catch_ups: dict[int, CatchUp], uav: int, clock: tuple[Vec3, Vec3] | None,
             now: float) -> tuple[Vec3, Vec3] | None:
    """`clock`, or UAV `uav`'s catch-up target while it has one (forgotten once caught up)."""
    c = catch_ups.get(uav)
    if c is None or clock is None:
        return clock
    target = c.target(clock, now)
    if target is None:
        del catch_ups[uav]
        return clock
    return target
