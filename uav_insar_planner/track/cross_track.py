"""Cross-track correction: the setpoint moved against the autopilot's own tracking error.

PX4's position loops (MPC_XY_P 0.95 /s, MPC_Z_P 1.0 /s, in SIH) let the vehicle wander slowly,
0.3-0.6 m over 5-15 s across track and in height, on a pass and in the hover before it; its
estimate follows the wander, so this is the loop's error, not the EKF's. A proportional-integral
correction from the setpoint side removes it without touching the pilot's tuning: with e the
across-track and height error of the autopilot's estimate p_hat (LOCAL_POSITION_NED) from the
target p, the setpoint sent is

    s = p + g e + k_i integral(e dt),   e = p - p_hat   (x and z only),

so the autopilot's own loop sees (1 + g) e plus the integral, which a slow disturbance cannot
outlast. The along-track position is the pass clock's (the bridge's start gate and catch-up
keep it), so y is never corrected. Bounds: an estimate older than FRESH_S adds nothing (the
loop would act on a past error) but keeps the integral learnt so far, as a loaded companion
computer or a lossy link delivers some late; without an estimate, or farther than TRUSTED_M
from the target (a transit or a vehicle out of reach is not a tracking error), the
correction is off and its integral forgotten; the integral is held within LIMIT_M and the
whole correction too.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from uav_insar_planner.plan import Vec3

FRESH_S = 0.3  # older estimates are not corrected on (LOCAL_POSITION_NED at 10 Hz: 0.1 s)
TRUSTED_M = 2.0  # a larger error is not a tracking error
LIMIT_M = 0.8  # the largest correction, and the largest integral part of it
INTEGRAL_GAIN = 1.0  # k_i [1/s]: a wander of 5-15 s is met with more than g adds
MAX_STEP_S = 0.5  # a longer gap between setpoints integrates no more than this


@dataclass
class CrossTrack:
    """One vehicle's correction: its gain g, and its integral of the error so far."""

    gain: float
    integral: tuple[float, float] = (0.0, 0.0)  # k_i * integral of (e_x, e_z) dt [m]
    last_s: float | None = None

    def setpoint(self, target: Vec3, estimate: Vec3 | None, age_s: float, now: float) -> Vec3:
        """The setpoint for track-frame `target` at `now`, given the autopilot's track-frame
        `estimate` (`age_s` old); `target` itself while the correction is off."""
        if self.gain <= 0.0 or estimate is None:
            return self._off(target, now)
        if not 0.0 <= age_s <= FRESH_S:  # a late estimate: hold what was learnt, add nothing
            self.last_s = now
            return (target[0] + self.integral[0], target[1], target[2] + self.integral[1])
        ex, ez = target[0] - estimate[0], target[2] - estimate[2]
        if math.hypot(ex, ez) > TRUSTED_M:
            return self._off(target, now)
        dt = 0.0 if self.last_s is None else min(max(now - self.last_s, 0.0), MAX_STEP_S)
        self.last_s = now
        ix, iz = (self.integral[0] + INTEGRAL_GAIN * ex * dt,
                  self.integral[1] + INTEGRAL_GAIN * ez * dt)
        self.integral = _within((ix, iz), LIMIT_M)
        cx, cz = _within((self.gain * ex + self.integral[0], self.gain * ez + self.integral[1]),
                         LIMIT_M)
        return (target[0] + cx, target[1], target[2] + cz)

    def _off(self, target: Vec3, now: float) -> Vec3:
        self.integral, self.last_s = (0.0, 0.0), now
        return target


def _within(v: tuple[float, float], limit: float) -> tuple[float, float]:
    """`v` scaled down to norm `limit` if longer."""
    norm = math.hypot(*v)
    return v if norm <= limit else (v[0] * limit / norm, v[1] * limit / norm)
