"""The flight logic of the simulated multicopter: boot, modes, arming, takeoff, setpoints.

No I/O: `SimVehicle` (simulator.py) decodes MAVLink into these calls and reports the state.
Results are MAV_RESULT numbers, as the real autopilots answer; STATUSTEXTs to send are queued
in `statustexts` as (severity, text) for the vehicle to drain.

- Boot: for `boot_s` after construction (none when started `airborne`) the estimator is "not
  ready": arming fails (ArduPilot FAILED, PX4 TEMPORARILY_REJECTED, with a PreArm STATUSTEXT),
  PX4 refuses every mode change (TEMPORARILY_REJECTED), and an ArduPilot mode set during boot
  is accepted but falls back to STABILIZE when boot ends (as ArduCopter SITL does).
- ArduPilot (Copter mode numbers): setpoints only in GUIDED, only after NAV_TAKEOFF when on
  the ground; velocity targets stop after 3 s; GUIDED requested while in GUIDED keeps the
  target. STABILIZE / ALT_HOLD (no RC modelled: sticks centred) stop and hold height, LOITER
  holds, BRAKE stops then holds, RTL climbs to `rtl_alt_m`, returns above home and lands,
  LAND descends and disarms. Arming is refused in RTL, LAND and BRAKE.
- PX4: MANUAL / ALTCTL / POSCTL / HOLD hold, TAKEOFF climbs then holds, LAND, RTL as above.
  OFFBOARD is accepted when the latest setpoint is recent (within `offboard_timeout_s`, as
  PX4's offboardCheck does with COM_OF_LOSS_T), and drops to HOLD when setpoints stop.
- Setpoints: position, velocity or both, all three axes of a group together, finite values
  only; offsets in the offset / body frames are from where the vehicle is (it never yaws).
- Point-mass dynamics (`kinematics.step_toward` with a P gain), speed <= `max_speed`,
  acceleration <= `max_accel`; the ground is D = max(0, start D); landing at 1 m/s.
- Wind (`wind_ned`, steady, m/s): off the ground it carries the vehicle, whose point-mass
  velocity is then its air velocity (as wind.py's for the self-flown agent; `velocity` is
  over the ground). The controller only sees the position error the wind causes, so a
  vehicle holding a target sits downwind of it by max(|w| / KP, |w|^2 / max_accel), the
  distance at which its approach speed matches the wind, as a real copter's does in a gust.
"""
from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.mavlink.setpoints import POSITION_BITS, VELOCITY_BITS
from uav_insar_sim.physics.kinematics import PointMass, step_toward
from uav_insar_sim.vehicle.profiles import vehicle_profile

KP = 1.5  # 1/s, position error -> velocity
ARDUPILOT_VELOCITY_TIMEOUT_S = 3.0
PX4_DEFAULT_TAKEOFF_M = 2.5  # MIS_TAKEOFF_ALT default
LAND_SPEED = 1.0
MAX_TAKEOFF_M = 1000.0
_ZERO = (0.0, 0.0, 0.0)


class Autopilot:
    """ArduCopter-like or PX4-like flight logic of one vehicle (see the module doc); what
    differs per flavour is its `profile` (`profiles.VehicleProfile`)."""

    def __init__(self, autopilot: str = "ardupilot",
                 start_ned: Sequence[float] = (0.0, 0.0, 0.0), max_speed: float = 10.0,
                 max_accel: float = 5.0, airborne: bool = False, offboard_timeout_s: float = 0.5,
                 boot_s: float = 0.0, now: float | None = None,
                 wind_ned: Sequence[float] = (0.0, 0.0, 0.0)):
        self.profile = vehicle_profile(autopilot)
        for name, value, high in (("max_speed", max_speed, 1000.0),
                                  ("max_accel", max_accel, 1000.0),
                                  ("offboard_timeout_s", offboard_timeout_s, 60.0)):
            if not 0.0 < value < high:  # (False for NaN)
                raise ValueError(f"{name}: value {value!r:.24} is not allowed; expected "
                                 f"0 < value < {high:g}")
        if len(start_ned) != 3 or not all(math.isfinite(c) and abs(c) < 1e6
                                          for c in start_ned):
            raise ValueError(f"start_ned: value {tuple(start_ned)!r:.60} is not allowed; "
                             "expected 3 finite numbers N E D within +-1e6 m")
        if len(wind_ned) != 3 or not all(math.isfinite(c) for c in wind_ned) or \
                not math.hypot(*wind_ned) < max_speed:
            raise ValueError(f"wind_mps: value {tuple(wind_ned)!r:.60} is not allowed; "
                             f"expected 3 finite numbers N E D [m/s], slower than the "
                             f"speed limit {max_speed:g} m/s")
        if not (0.0 <= boot_s < 3600.0):
            raise ValueError(f"boot_s: value {boot_s!r:.24} is not allowed; expected "
                             "0 <= s < 3600")
        self.max_speed, self.max_accel = float(max_speed), float(max_accel)
        self.offboard_timeout_s = float(offboard_timeout_s)
        self.takeoff_alt_m = PX4_DEFAULT_TAKEOFF_M
        self.rtl_alt_m = self.profile.rtl_alt_m
        self.boot_s = 0.0 if airborne else float(boot_s)
        self.boot_end = (time.monotonic() if now is None else now) + self.boot_s
        self._booted = self.boot_s == 0.0
        self.statustexts: list[tuple[int, str]] = []
        self.state = PointMass(np.array(start_ned, dtype=float), np.zeros(3))
        self.wind = np.array(wind_ned, dtype=float)
        self.ground_d = max(0.0, float(start_ned[2]))
        self.home = np.array([start_ned[0], start_ned[1], self.ground_d], dtype=float)
        self.armed = airborne
        self.mode = self.profile.autopilot.flight.name if airborne else self.profile.ground_mode
        self._hold = self.state.position.copy()  # where hold / loiter / guided-no-target stays
        self._braking = False
        self._target_pos: np.ndarray | None = None
        self._target_vel: np.ndarray | None = None
        self._target_time = 0.0
        self._takeoff_d: float | None = None
        self._last_setpoint: float | None = None
        self.setpoints_accepted = 0
        self.setpoints_rejected = 0

    @property
    def position(self) -> tuple[float, float, float]:
        return tuple(float(c) for c in self.state.position)

    @property
    def velocity(self) -> tuple[float, float, float]:
        """Over the ground: the wind's push added in the air."""
        v = self.state.velocity + self.wind if self._in_the_wind() else self.state.velocity
        return tuple(float(c) for c in v)

    def _in_the_wind(self) -> bool:
        return self.armed and not self.on_ground()

    def on_ground(self) -> bool:
        return (self.state.position[2] >= self.ground_d - 0.05
                and self.state.velocity[2] >= -0.05)

    def booted(self, now: float) -> bool:
        """True once the boot phase is over (position estimate, home, armable)."""
        if not self._booted and now >= self.boot_end:
            self._booted = True
            fallback = self.profile.boot_fallback_mode
            if fallback is not None and self.mode != fallback:
                self._enter(fallback)  # ArduCopter: a mode set while booting does not stick
        return self._booted

    def landed_state(self) -> int:
        """MAV_LANDED_STATE for EXTENDED_SYS_STATE."""
        if self.on_ground():
            return MAV.MAV_LANDED_STATE_ON_GROUND
        if self.mode == "LAND" or (self.mode == "RTL" and self._rtl_descending()):
            return MAV.MAV_LANDED_STATE_LANDING
        if self.mode == "TAKEOFF":
            return MAV.MAV_LANDED_STATE_TAKEOFF
        return MAV.MAV_LANDED_STATE_IN_AIR

    # --------------------------------------------------------------------- modes, arming
    def set_mode(self, custom: int, main: int, sub: int, now: float) -> int:
        """Switch mode: by custom mode `custom` or (main, sub), as the flavour names them."""
        p = self.profile
        name = p.mode_named(custom, main, sub)
        if name is None:
            return p.unknown_mode
        if p.refuses_while_booting and not self.booted(now):
            return MAV.MAV_RESULT_TEMPORARILY_REJECTED
        if name == "OFFBOARD":
            if not self._recent_setpoint(now):
                return MAV.MAV_RESULT_TEMPORARILY_REJECTED
            self._target_time = now
        elif name == p.takeoff_mode:
            return self.takeoff(float("nan"), now)
        if p.mode_change_clears_target:
            if name == self.mode:
                return MAV.MAV_RESULT_ACCEPTED  # ArduCopter: no change, GUIDED keeps its target
            self._target_pos = self._target_vel = None  # a new GUIDED session: no target
        self._enter(name)
        return MAV.MAV_RESULT_ACCEPTED

    def land(self) -> int:
        self._enter("LAND")
        return MAV.MAV_RESULT_ACCEPTED

    def rtl(self, now: float) -> int:
        if self.profile.refuses_while_booting and not self.booted(now):
            return MAV.MAV_RESULT_TEMPORARILY_REJECTED
        self._enter("RTL")
        return MAV.MAV_RESULT_ACCEPTED

    def arm(self, arm: bool, force: bool, now: float) -> int:
        """Arm, or disarm (in flight only with `force`)."""
        p = self.profile
        if arm:
            if self.armed:
                return MAV.MAV_RESULT_ACCEPTED
            if not self.booted(now) and not force:
                self.statustexts.append((MAV.MAV_SEVERITY_CRITICAL, p.prearm_text))
                return p.boot_arm_refusal
            if self.mode == "OFFBOARD" and not self._recent_setpoint(now):
                return MAV.MAV_RESULT_DENIED
            if self.mode in p.not_armable_modes and not force:
                self.statustexts.append((MAV.MAV_SEVERITY_CRITICAL, "Arm: Mode not armable"))
                return MAV.MAV_RESULT_FAILED
            self.home = self.state.position.copy()  # both autopilots set home on arming
            self.armed = True
            return MAV.MAV_RESULT_ACCEPTED
        if not self.on_ground() and not force:
            return p.refused
        self.armed = False
        return MAV.MAV_RESULT_ACCEPTED

    def takeoff(self, height: float, now: float | None = None) -> int:
        """NAV_TAKEOFF to `height` m above home (PX4: NaN for MIS_TAKEOFF_ALT)."""
        p = self.profile
        if not self.armed or not (math.isnan(height) or -MAX_TAKEOFF_M < height < MAX_TAKEOFF_M):
            return p.refused
        if p.takeoff_mode is not None:
            height = self.takeoff_alt_m if math.isnan(height) or height < 0.5 else height
            self._enter(p.takeoff_mode)
        elif self.mode != p.autopilot.flight.name or not self.on_ground() or not height > 0:
            return p.refused
        self._takeoff_d = float(self.home[2]) - height
        self._hold = np.array([self.state.position[0], self.state.position[1],
                               self._takeoff_d])
        return MAV.MAV_RESULT_ACCEPTED

    def setpoint(self, frame: int, mask: int, position: Sequence[float],
                 velocity: Sequence[float], now: float) -> bool:
        """One SET_POSITION_TARGET_LOCAL_NED; False (and counted) when it is refused."""
        p = self.profile
        pos_bits, vel_bits = mask & POSITION_BITS, mask & VELOCITY_BITS
        use_pos, use_vel = pos_bits == 0, vel_bits == 0
        valid_groups = pos_bits in (0, POSITION_BITS) and vel_bits in (0, VELOCITY_BITS)
        finite = (not use_pos or all(math.isfinite(c) and abs(c) < 1e6 for c in position)) \
            and (not use_vel or all(math.isfinite(c) and abs(c) < 1e3 for c in velocity))
        if frame not in p.frames or not valid_groups or not (use_pos or use_vel) or not finite:
            self.setpoints_rejected += 1
            return False
        if p.autopilot.setpoints_in_flight_only and self.mode != p.autopilot.flight.name:
            self.setpoints_rejected += 1  # ArduPilot ignores targets outside GUIDED
            return False
        goal = np.array(position, dtype=float)
        if frame != MAV.MAV_FRAME_LOCAL_NED:  # offsets from where we are
            goal = self.state.position + goal
        self._target_pos = goal if use_pos else None
        self._target_vel = np.array(velocity, dtype=float) if use_vel else None
        self._target_time = now
        self._last_setpoint = now
        self.setpoints_accepted += 1
        return True

    def _recent_setpoint(self, now: float) -> bool:
        return self._last_setpoint is not None and \
            now - self._last_setpoint <= self.offboard_timeout_s

    def _enter(self, mode: str) -> None:
        self.mode = mode
        self._hold = self.state.position.copy()
        self._braking = mode in ("BRAKE", "STABILIZE", "ALT_HOLD", "ALTCTL", "MANUAL")
        if mode in ("LAND", "RTL"):
            self._takeoff_d = None

    # ------------------------------------------------------------------------- dynamics
    def tick(self, dt: float, now: float) -> None:
        """Advance the flight by `dt` seconds; the ground stops the vehicle."""
        self.booted(now)
        goal, feed_forward = self._goal(now)
        in_the_wind = self._in_the_wind()
        self.state = step_toward(self.state, goal, dt, self.max_speed, self.max_accel,
                                 feed_forward, gain=KP)
        pos, vel = self.state.position, self.state.velocity
        if in_the_wind:
            pos += self.wind * dt
        if pos[2] > self.ground_d:
            pos[2] = self.ground_d
            vel[2] = min(vel[2], 0.0)
            if not self.armed:
                vel[:] = 0.0

    def _rtl_descending(self) -> bool:
        return float(np.hypot(*(self.state.position[:2] - self.home[:2]))) < 0.5

    def _descend(self) -> tuple[np.ndarray | None, Sequence[float]]:
        if self.on_ground():
            self.armed = False
            return None, _ZERO
        return None, (0.0, 0.0, LAND_SPEED)

    def _goal(self, now: float) -> tuple[np.ndarray | None, Sequence[float]]:
        """(position to reach or None, feed-forward velocity) for the current mode."""
        if not self.armed:
            return None, _ZERO
        if self.mode == "LAND":
            return self._descend()
        if self.mode == "RTL":
            return self._rtl()
        if self._braking:  # stop, then hold where it stopped (height kept)
            if float(np.linalg.norm(self.state.velocity)) > 0.1:
                return None, _ZERO
            self._braking = False
            self._hold = self.state.position.copy()
            return self._hold, _ZERO
        if self.mode == "OFFBOARD":
            # (--airborne starts in OFFBOARD with no stream yet; the loss needs a stream)
            if self._last_setpoint is not None and not self._recent_setpoint(now):
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

    def _rtl(self) -> tuple[np.ndarray | None, Sequence[float]]:
        """Climb to rtl_alt_m above home (if lower), fly above home, then land there."""
        pos = self.state.position
        if self._rtl_descending():
            if self.on_ground():
                return self._descend()
            return np.array([self.home[0], self.home[1], pos[2]]), (0.0, 0.0, LAND_SPEED)
        return_d = min(float(pos[2]), float(self.home[2]) - self.rtl_alt_m)
        if pos[2] > return_d + 0.5:
            return np.array([pos[0], pos[1], return_d]), _ZERO
        return np.array([self.home[0], self.home[1], return_d]), _ZERO
