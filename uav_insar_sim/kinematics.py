"""Point-mass kinematics with bounded speed and acceleration (mission time, SI units).

`step_toward` flies a point mass to a (possibly moving) target: it commands the velocity that
still lets it brake within `max_accel` (sqrt(2 a d) toward the target, plus the target's own
velocity), limited to `max_speed`, and changes velocity by at most `max_accel * dt` per step.
`along_track` is the stripmap run: from rest at y = -runup_distance, accelerate at `accel` to
reach `speed` exactly at y = 0, then fly at constant speed, so slot n (0-based) starts at
track time speed/accel + n delta_t at y = n v_y delta_t, as the model's y[n] requires.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class PointMass:
    """Position and velocity, arrays of the same dimension (2-D across-track or 3-D)."""

    position: np.ndarray
    velocity: np.ndarray


def step_toward(state: PointMass, target: np.ndarray, dt: float, max_speed: float,
                max_accel: float, target_velocity: np.ndarray | None = None) -> PointMass:
    """Advance `state` by `dt` toward `target` with |v| <= max_speed and |a| <= max_accel.

    `target` is where the target is now; it moves at `target_velocity` (default at rest).

    When the target is within one step at speed max_accel * dt (and the velocity nearly
    matched), the state lands exactly on it: a settled vehicle then holds its target with no
    numerical jitter.
    """
    target = np.asarray(target, dtype=float)
    v_t = np.zeros_like(target) if target_velocity is None else np.asarray(target_velocity,
                                                                             dtype=float)
    error = target - state.position
    dist = float(np.linalg.norm(error))
    dv_max = max_accel * dt
    if dist <= dv_max * dt and float(np.linalg.norm(state.velocity - v_t)) <= dv_max:
        return PointMass(target + v_t * dt, v_t.copy())
    # Highest approach speed that can still brake to zero relative speed at the target in
    # whole steps of dt (the discrete form of sqrt(2 a d); it avoids creeping in at the end).
    approach = min(max_speed, dv_max * (np.sqrt(2.0 * dist / (dv_max * dt) + 0.25) - 0.5))
    desired = v_t + (error / dist * approach if dist > 0.0 else 0.0)
    speed = float(np.linalg.norm(desired))
    if speed > max_speed:
        desired *= max_speed / speed
    dv = desired - state.velocity
    dv_norm = float(np.linalg.norm(dv))
    if dv_norm > dv_max:
        dv *= dv_max / dv_norm
    velocity = state.velocity + dv
    # Semi-implicit Euler: the braking law above is exact for this update.
    position = state.position + velocity * dt
    return PointMass(position, velocity)


def runup_distance(speed: float, accel: float) -> float:
    """Distance needed to reach `speed` from rest at `accel`: v^2 / (2 a)."""
    return speed * speed / (2.0 * accel)


def along_track(tau: float, speed: float, accel: float) -> tuple[float, float]:
    """(y, v_y) at track time `tau` >= 0 of the run-up-then-cruise profile (see module doc)."""
    t_up = speed / accel
    if tau < t_up:
        return -runup_distance(speed, accel) + 0.5 * accel * tau * tau, accel * tau
    return speed * (tau - t_up), speed


def slot_start(n: int, speed: float, accel: float, slot_duration: float) -> float:
    """Track time at which slot n (0-based) starts: the run-up, then n slot durations."""
    return speed / accel + n * slot_duration
