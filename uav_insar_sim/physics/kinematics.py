"""Point-mass kinematics with bounded speed and acceleration (SI units), one integrator for
the self-flown agent and the simulated MAVLink vehicle.

`step_toward` flies a point mass to a (possibly moving) target, or at a commanded velocity:
it commands the target's own velocity plus an approach speed toward the target that still
lets it brake, limited to `max_speed`, and changes velocity by at most `max_accel * dt` per
step. Two braking laws:
- gain None (the agent's own flight): sqrt(2 a d) in whole steps, braking at the full
  `max_accel` and landing exactly on the target;
- gain K (an autopilot's position controller): min(K d, sqrt(a d)), braking with half the
  acceleration limit, never snapping onto the target.

`runup_and_cruise` is the stripmap run: from rest at y = -runup_distance, accelerate at
`accel` to reach `speed` exactly at y = 0, then fly at constant speed, so slot n (0-based)
starts at track time speed/accel + n delta_t at y = n v_y delta_t, as the model's y[n]
requires.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass
class PointMass:
    """Position and velocity, arrays of the same dimension (2-D across-track or 3-D)."""

    position: np.ndarray
    velocity: np.ndarray


def step_toward(state: PointMass, target: np.ndarray | None, dt: float, max_speed: float,
                max_accel: float, target_velocity: np.ndarray | None = None,
                gain: float | None = None) -> PointMass:
    """Advance `state` by `dt` toward `target` with |v| <= max_speed and |a| <= max_accel.

    `target` is where the target is now; it moves at `target_velocity` (default at rest).
    `target` None is a pure velocity command: fly at `target_velocity` (default: stop).
    `gain` picks the braking law (module doc).

    With gain None, when the target is within one step at speed max_accel * dt (and the
    velocity nearly matched), the state lands exactly on it: a settled vehicle then holds its
    target with no numerical jitter.
    """
    v_t = (np.zeros_like(state.velocity, dtype=float) if target_velocity is None
           else np.asarray(target_velocity, dtype=float))
    dv_max = max_accel * dt
    desired = v_t.copy()
    if target is not None:
        target = np.asarray(target, dtype=float)
        error = target - state.position
        dist = float(np.linalg.norm(error))
        if gain is None:
            if dist <= dv_max * dt and float(np.linalg.norm(state.velocity - v_t)) <= dv_max:
                return PointMass(target + v_t * dt, v_t.copy())
            # Highest approach speed that can still brake to zero relative speed at the
            # target in whole steps of dt (the discrete sqrt(2 a d); no creeping in at the end).
            approach = min(max_speed, dv_max * (np.sqrt(2.0 * dist / (dv_max * dt) + 0.25)
                                                - 0.5))
        else:
            # Slow down early enough to stop at the goal with half the accel limit.
            approach = min(max_speed, gain * dist, math.sqrt(max_accel * dist))
        if dist > 0.0:
            desired = desired + error / dist * approach
    speed = float(np.linalg.norm(desired))
    if speed > max_speed:
        desired = desired * (max_speed / speed)
    dv = desired - state.velocity
    dv_norm = float(np.linalg.norm(dv))
    if dv_norm > dv_max:
        dv = dv * (dv_max / dv_norm)
    velocity = state.velocity + dv
    # Semi-implicit Euler: the braking law above is exact for this update.
    position = state.position + velocity * dt
    return PointMass(position, velocity)


def runup_distance(speed: float, accel: float) -> float:
    """Distance needed to reach `speed` from rest at `accel`: v^2 / (2 a)."""
    return speed * speed / (2.0 * accel)


def runup_and_cruise(tau: float, speed: float, accel: float) -> tuple[float, float]:
    """(y, v_y) at track time `tau` >= 0 of the run-up-then-cruise profile (see module doc)."""
    t_up = speed / accel
    if tau < t_up:
        return -runup_distance(speed, accel) + 0.5 * accel * tau * tau, accel * tau
    return speed * (tau - t_up), speed


def slot_start(n: int, speed: float, accel: float, slot_duration: float) -> float:
    """Track time at which slot n (0-based) starts: the run-up, then n slot durations."""
    return speed / accel + n * slot_duration
