"""The along-track speed of a pass: up from a hover, cruising at v_y, braking at its end.

A target that jumped to v_y would leave a hovering copter behind, to catch up at v_y + 1-2 m/s
(measured in the network lab: 5.5-6 m/s at 4.3), and one that stopped dead would make every
vehicle overshoot by v^2 / (2 a_max) and come back. So the target accelerates at RAMP_MPS2
from a hover (`ramp_up`), and brakes at BRAKE_MPS2 to stop exactly at the end of a finite
pass (`braked_pass`). A pass ramped up runs v_y / (2 RAMP_MPS2) behind the unramped clock
(`ramp_delay_s`: 1.4 s at Table I's 4.3 m/s).
"""
from __future__ import annotations

import math

# Gentle for a multicopter's position controller, at both ends of a pass.
BRAKE_MPS2 = 1.5
RAMP_MPS2 = BRAKE_MPS2


def ramp_up(elapsed: float, speed: float) -> tuple[float, float, float]:
    """(offset, velocity, shift) `elapsed` seconds after a start from rest: RAMP_MPS2 up to
    `speed`, then cruising; shift = how far behind an unramped clock it runs then (seconds,
    0 while still accelerating)."""
    if speed <= 0.0:
        return 0.0, 0.0, 0.0
    t_ramp = speed / RAMP_MPS2
    if elapsed < t_ramp:
        return 0.5 * RAMP_MPS2 * elapsed * elapsed, RAMP_MPS2 * elapsed, 0.0
    return speed * (elapsed - 0.5 * t_ramp), speed, 0.5 * t_ramp


def ramp_delay_s(speed: float) -> float:
    """How far behind an unramped clock a pass ramped up from a hover runs [s]."""
    return ramp_up(speed / RAMP_MPS2, speed)[2] if speed > 0.0 else 0.0


def _braking(speed: float, duration: float) -> tuple[float, float]:
    """(when the braking starts, its deceleration) of a pass of `duration` s at `speed`: at
    BRAKE_MPS2, or harder for a pass too short, so that cruise and braking add up to
    speed * duration."""
    brake_s = min(speed / BRAKE_MPS2, 2.0 * duration)
    return duration - brake_s / 2.0, speed / brake_s


def braked_pass(elapsed: float, speed: float, duration: float) -> tuple[float, float]:
    """(offset, velocity) of the along-track target `elapsed` seconds into the pass.

    duration 0: cruise at `speed` for ever. Otherwise cruise, then brake (`_braking`) so that
    the target stops exactly at speed * duration.
    """
    if duration <= 0.0:
        return speed * elapsed, speed
    if speed <= 0.0:
        return 0.0, 0.0
    t_brake, decel = _braking(speed, duration)
    if elapsed <= t_brake:
        return speed * elapsed, speed
    tau = min(elapsed - t_brake, speed / decel)
    return speed * t_brake + speed * tau - 0.5 * decel * tau * tau, speed - decel * tau


def braked_time_s(distance_m: float, speed: float, duration: float) -> float:
    """When `braked_pass`'s target is `distance_m` along (the inverse of its offset; inf
    beyond the end of a finite pass, where it stops; `speed` > 0)."""
    if duration <= 0.0:
        return distance_m / speed
    end = speed * duration
    if distance_m > end + 1e-9 * max(1.0, end):  # (the end itself, to rounding, is reached)
        return math.inf
    distance_m = min(distance_m, end)
    t_brake, decel = _braking(speed, duration)
    if distance_m <= speed * t_brake:
        return distance_m / speed
    rest = distance_m - speed * t_brake
    return t_brake + (speed - math.sqrt(max(speed * speed - 2.0 * decel * rest, 0.0))) / decel
