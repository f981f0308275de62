"""The flight logic of the simulated multicopter: modes, arming, takeoff, setpoints, dynamics.

No I/O: `SimVehicle` (vehicle.py) decodes MAVLink into these calls and reports the state.
Results are MAV_RESULT numbers, as the real autopilots answer.

- ArduPilot (Copter mode numbers): setpoints only in GUIDED, only after NAV_TAKEOFF when on
  the ground; velocity targets stop after 3 s.
- PX4: setpoints are the offboard "proof of life"; OFFBOARD is refused
  (TEMPORARILY_REJECTED) until they have streamed for > 1 s, and the vehicle drops to HOLD
  (AUTO.LOITER) when they stop for `offboard_timeout_s`.
- Setpoints: position, velocity or both, all three axes of a group together; offsets in the
  offset / body frames are from where the vehicle is (it never yaws, so body axes are NED).
- Point-mass dynamics (`kinematics.step_toward` with a P gain), speed <= `max_speed`,
  acceleration <= `max_accel`; the ground is D = max(0, start D); LAND descends at 1 m/s and
  disarms on touchdown.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from uav_insar_planner.mavlink.autopilots import AUTOPILOTS, COPTER_MODES, PX4_MODES
from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.mavlink.setpoints import POSITION_BITS, VELOCITY_BITS
from uav_insar_sim.kinematics import PointMass, step_toward

KP = 1.5  # 1/s, position error -> velocity
ARDUPILOT_FRAMES = frozenset((MAV.MAV_FRAME_LOCAL_NED, MAV.MAV_FRAME_LOCAL_OFFSET_NED,
                              MAV.MAV_FRAME_BODY_NED, MAV.MAV_FRAME_BODY_OFFSET_NED))
PX4_FRAMES = frozenset((MAV.MAV_FRAME_LOCAL_NED, MAV.MAV_FRAME_BODY_NED))
ARDUPILOT_VELOCITY_TIMEOUT_S = 3.0
PX4_STREAM_REQUIRED_S = 1.0
PX4_DEFAULT_TAKEOFF_M = 2.5  # MIS_TAKEOFF_ALT default
LAND_SPEED = 1.0
_ZERO = (0.0, 0.0, 0.0)


class Autopilot:
    """ArduCopter-like or PX4-like flight logic of one vehicle (see the module doc)."""

    def __init__(self, autopilot: str = "ardupilot",
                 start_ned: Sequence[float] = (0.0, 0.0, 0.0), max_speed: float = 10.0,
                 max_accel: float = 5.0, airborne: bool = False, offboard_timeout_s: float = 0.5):
        if autopilot not in AUTOPILOTS:
            raise ValueError(f"autopilot: {autopilot!r} is not allowed; expected ardupilot "
                             "or px4")
        if not (max_speed > 0 and max_accel > 0 and math.isfinite(max_speed + max_accel)):
            raise ValueError("speed and accel must be finite and > 0")
        if len(start_ned) != 3 or not all(math.isfinite(c) for c in start_ned):
            raise ValueError("start_ned: expected 3 finite numbers N E D")
        self.autopilot = autopilot
        self.px4 = autopilot == "px4"
        self.max_speed, self.max_accel = float(max_speed), float(max_accel)
        self.offboard_timeout_s = offboard_timeout_s
        self.state = PointMass(np.array(start_ned, dtype=float), np.zeros(3))
        self.ground_d = max(0.0, float(start_ned[2]))
        self._home_d = self.ground_d
        self.armed = airborne
        self.mode = ("OFFBOARD" if self.px4 else "GUIDED") if airborne else (
            "POSCTL" if self.px4 else "STABILIZE")
        self._hold = self.state.position.copy()  # where hold / loiter / guided-no-target stays
        self._target_pos: np.ndarray | None = None
        self._target_vel: np.ndarray | None = None
        self._target_time = 0.0
        self._takeoff_d: float | None = None
        self._stream_start: float | None = None
        self._last_setpoint: float | None = None
        self.setpoints_accepted = 0
        self.setpoints_rejected = 0

    @property
    def position(self) -> tuple[float, float, float]:
        return tuple(float(c) for c in self.state.position)

    @property
    def velocity(self) -> tuple[float, float, float]:
        return tuple(float(c) for c in self.state.velocity)

    def on_ground(self) -> bool:
        return (self.state.position[2] >= self.ground_d - 0.05
                and self.state.velocity[2] >= -0.05)

    # --------------------------------------------------------------------- modes, arming
    def set_mode(self, custom: int, main: int, sub: int, now: float) -> int:
        """Switch mode: ArduPilot by Copter number `custom`, PX4 by (main, sub)."""
        if self.px4:
            names = [n for n, (m, s) in PX4_MODES.items() if m == main and (s == sub or m != 4)]
            if not names:
                return MAV.MAV_RESULT_UNSUPPORTED
            name = names[0]
            if name == "OFFBOARD":
                if not self._streaming(now):
                    return MAV.MAV_RESULT_TEMPORARILY_REJECTED
                self._target_time = now
            elif name == "TAKEOFF":
                return self.takeoff(float("nan"))
        else:
            names = [n for n, number in COPTER_MODES.items() if number == custom]
            if not names:
                return MAV.MAV_RESULT_FAILED
            name = names[0]
            self._target_pos = self._target_vel = None  # a new GUIDED session: no target
        self._enter(name)
        return MAV.MAV_RESULT_ACCEPTED

    def land(self) -> int:
        self._enter("LAND")
        return MAV.MAV_RESULT_ACCEPTED

    def arm(self, arm: bool, force: bool, now: float) -> int:
        """Arm, or disarm (in flight only with `force`)."""
        if arm:
            if self.px4 and self.mode == "OFFBOARD" and not self._streaming(now):
                return MAV.MAV_RESULT_DENIED
            if not self.armed:
                self._home_d = float(self.state.position[2])
            self.armed = True
            return MAV.MAV_RESULT_ACCEPTED
        if not self.on_ground() and not force:
            return MAV.MAV_RESULT_DENIED if self.px4 else MAV.MAV_RESULT_FAILED
        self.armed = False
        return MAV.MAV_RESULT_ACCEPTED

    def takeoff(self, altitude: float) -> int:
        """NAV_TAKEOFF to `altitude` m above home (PX4: NaN for its default height)."""
        if not self.armed:
            return MAV.MAV_RESULT_DENIED if self.px4 else MAV.MAV_RESULT_FAILED
        if self.px4:
            # PX4's param7 is AMSL; the sim's home is at 0 m AMSL, so it is the height.
            height = PX4_DEFAULT_TAKEOFF_M if math.isnan(altitude) else altitude
            self._enter("TAKEOFF")
        else:
            if self.mode != "GUIDED" or not self.on_ground() or not altitude > 0:
                return MAV.MAV_RESULT_FAILED
            height = altitude
        self._takeoff_d = self._home_d - height
        self._hold = np.array([self.state.position[0], self.state.position[1],
                               self._takeoff_d])
        return MAV.MAV_RESULT_ACCEPTED

    def setpoint(self, frame: int, mask: int, position: Sequence[float],
                 velocity: Sequence[float], now: float) -> bool:
        """One SET_POSITION_TARGET_LOCAL_NED; False (and counted) when it is refused."""
        frames = PX4_FRAMES if self.px4 else ARDUPILOT_FRAMES
        pos_bits, vel_bits = mask & POSITION_BITS, mask & VELOCITY_BITS
        use_pos, use_vel = pos_bits == 0, vel_bits == 0
        valid_groups = pos_bits in (0, POSITION_BITS) and vel_bits in (0, VELOCITY_BITS)
        if frame not in frames or not valid_groups or not (use_pos or use_vel):
            self.setpoints_rejected += 1
            return False
        if not self.px4 and self.mode != "GUIDED":
            self.setpoints_rejected += 1  # ArduPilot ignores targets outside GUIDED
            return False
        goal = np.array(position, dtype=float)
        if frame != MAV.MAV_FRAME_LOCAL_NED:  # offsets from where we are
            goal = self.state.position + goal
        self._target_pos = goal if use_pos else None
        self._target_vel = np.array(velocity, dtype=float) if use_vel else None
        self._target_time = now
        if self._last_setpoint is None or now - self._last_setpoint > self.offboard_timeout_s:
            self._stream_start = now
        self._last_setpoint = now
        self.setpoints_accepted += 1
        return True

    def _streaming(self, now: float) -> bool:
        return (self._last_setpoint is not None
                and now - self._last_setpoint <= self.offboard_timeout_s
                and now - self._stream_start > PX4_STREAM_REQUIRED_S)

    def _enter(self, mode: str) -> None:
        self.mode = mode
        self._hold = self.state.position.copy()
        if mode == "LAND":
            self._takeoff_d = None

    # ------------------------------------------------------------------------- dynamics
    def tick(self, dt: float, now: float) -> None:
        """Advance the flight by `dt` seconds; the ground stops the vehicle."""
        goal, feed_forward = self._goal(now)
        self.state = step_toward(self.state, goal, dt, self.max_speed, self.max_accel,
                                 feed_forward, gain=KP)
        pos, vel = self.state.position, self.state.velocity
        if pos[2] > self.ground_d:
            pos[2] = self.ground_d
            vel[2] = min(vel[2], 0.0)
            if not self.armed:
                vel[:] = 0.0

    def _goal(self, now: float) -> tuple[np.ndarray | None, Sequence[float]]:
        """(position to reach or None, feed-forward velocity) for the current mode."""
        if not self.armed:
            return None, _ZERO
        if self.mode == "LAND":
            if self.on_ground():
                self.armed = False
                return None, _ZERO
            return None, (0.0, 0.0, LAND_SPEED)
        if self.mode == "OFFBOARD":
            # (--airborne starts in OFFBOARD with no stream yet; the loss needs a stream)
            if self._last_setpoint is not None and \
                    now - self._last_setpoint > self.offboard_timeout_s:
                self._enter("HOLD")  # PX4's offboard-loss failsafe without RC
                return self._hold, _ZERO
        elif self.mode == "GUIDED":
            if self._takeoff_d is not None and self._target_pos is None and \
                    self._target_vel is None:
                return self._hold, _ZERO
            if self.on_ground() and self._takeoff_d is None:
                return None, _ZERO  # ArduCopter: landed, needs NAV_TAKEOFF first
            if self._target_pos is None and self._target_vel is not None and \
                    now - self._target_time > ARDUPILOT_VELOCITY_TIMEOUT_S:
                self._target_vel = None
                self._hold = self.state.position.copy()
            if self._target_pos is None and self._target_vel is None:
                return self._hold, _ZERO
        elif self.mode == "TAKEOFF":
            if abs(self.state.position[2] - self._takeoff_d) < 0.2:
                self._enter("HOLD")
            return self._hold, _ZERO
        else:
            return self._hold, _ZERO
        if self._target_pos is None and self._target_vel is None:
            return self.state.position.copy(), _ZERO
        return self._target_pos, (_ZERO if self._target_vel is None else self._target_vel)
