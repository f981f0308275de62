"""A SITL-style MAVLink multicopter: enough of ArduCopter or PX4 to fly the bridge against.

Command line (the `uav-insar-vehicle` console script, or `python -m uav_insar_sim.vehicle`):

    uav-insar-vehicle --sysid 2 --listen udpin:127.0.0.1:14552 [--autopilot ardupilot|px4]
                      [--start-ned N E D] [--speed 10] [--accel 5] [--airborne]

In-process (a background thread; what tests and an agent node use):

    with SimVehicle(sysid=2, listen="udpin:127.0.0.1:0", autopilot="px4") as vehicle:
        port = vehicle.port              # the bound UDP port (0 picks a free one)
        vehicle.position_ned             # (N, E, D) in metres, thread-safe snapshot
        vehicle.mode, vehicle.armed, vehicle.landed
        vehicle.set_radio(False)         # drop all traffic both ways (a link loss)

What it does, like the real autopilots (and where it is simpler):
- HEARTBEAT at 1 Hz as (sysid, compid 1), MAV_TYPE_QUADROTOR, autopilot ARDUPILOTMEGA with
  Copter mode numbers (STABILIZE 0, GUIDED 4, LOITER 5, LAND 9) or PX4 with
  custom_mode = main << 16 | sub << 24 (POSCTL, OFFBOARD, AUTO.TAKEOFF/LOITER/LAND).
- LOCAL_POSITION_NED at 10 Hz (MAV_CMD_SET_MESSAGE_INTERVAL changes it).
- COMMAND_LONG ARM_DISARM, DO_SET_MODE, NAV_TAKEOFF, NAV_LAND, SET_MESSAGE_INTERVAL and the
  SET_MODE message are answered with COMMAND_ACK; other commands get UNSUPPORTED.
- SET_POSITION_TARGET_LOCAL_NED: frames LOCAL_NED, LOCAL_OFFSET_NED, BODY_NED,
  BODY_OFFSET_NED for ArduPilot, LOCAL_NED and BODY_NED for PX4 (others are rejected and
  counted); type_mask honoured for position, velocity or both (all three axes of a group
  together, as both autopilots require); acceleration fields are ignored. The sim never yaws,
  so body axes equal NED axes. A mask of 0 means "use every field", so x = y = z = 0 flies
  the vehicle to the origin, just as on the real thing.
- ArduPilot: setpoints only in GUIDED, only after NAV_TAKEOFF when on the ground; velocity
  targets stop after 3 s. PX4: setpoints are the offboard "proof of life"; OFFBOARD is
  refused (TEMPORARILY_REJECTED) until they have streamed for > 1 s, and the vehicle drops to
  AUTO.LOITER (hold) when they stop for `offboard_timeout_s` (0.5 s).
- Point-mass dynamics at 50 Hz, speed <= `max_speed`, acceleration <= `max_accel`; the
  ground is D = max(0, start D); LAND descends at 1 m/s and disarms on touchdown.
"""
from __future__ import annotations

import argparse
import math
import select
import sys
import threading
import time
from dataclasses import replace

from uav_insar_planner.mavlink.link import MAV, Link, LinkStats

AUTOPILOTS = ("ardupilot", "px4")
PHYSICS_HZ = 50.0
KP = 1.5  # 1/s, position error -> velocity
ARDUPILOT_FRAMES = frozenset((MAV.MAV_FRAME_LOCAL_NED, MAV.MAV_FRAME_LOCAL_OFFSET_NED,
                              MAV.MAV_FRAME_BODY_NED, MAV.MAV_FRAME_BODY_OFFSET_NED))
PX4_FRAMES = frozenset((MAV.MAV_FRAME_LOCAL_NED, MAV.MAV_FRAME_BODY_NED))
POS_BITS, VEL_BITS = 0b111, 0b111000
COPTER_MODES = {"STABILIZE": 0, "GUIDED": 4, "LOITER": 5, "LAND": 9}
PX4_MODES = {"POSCTL": (3, 0), "OFFBOARD": (6, 0), "TAKEOFF": (4, 2), "HOLD": (4, 3),
             "LAND": (4, 6)}
ARDUPILOT_VELOCITY_TIMEOUT_S = 3.0
PX4_STREAM_REQUIRED_S = 1.0
PX4_DEFAULT_TAKEOFF_M = 2.5  # MIS_TAKEOFF_ALT default
FORCE_DISARM_MAGIC = 21196
LAND_SPEED = 1.0


def px4_custom_mode(name: str) -> int:
    main, sub = PX4_MODES[name]
    return (main << 16) | (sub << 24)


class SimVehicle:
    """One simulated multicopter on one MAVLink endpoint (see the module doc for behaviour).

    The constructor opens the link (ValueError if it cannot); `start()` runs the vehicle in a
    daemon thread, `stop()` ends it and closes the link; `run(stop_event)` runs in the
    calling thread instead (the CLI). Properties are thread-safe snapshots.
    """

    def __init__(self, sysid: int, listen: str, autopilot: str = "ardupilot",
                 start_ned: tuple[float, float, float] = (0.0, 0.0, 0.0),
                 max_speed: float = 10.0, max_accel: float = 5.0, airborne: bool = False,
                 offboard_timeout_s: float = 0.5, compid: int = MAV.MAV_COMP_ID_AUTOPILOT1):
        if autopilot not in AUTOPILOTS:
            raise ValueError(f"autopilot: {autopilot!r} is not allowed; expected ardupilot "
                             "or px4")
        if not 1 <= sysid <= 255:
            raise ValueError(f"sysid: {sysid!r} is not allowed; expected 1..255")
        if not (max_speed > 0 and max_accel > 0 and math.isfinite(max_speed + max_accel)):
            raise ValueError("speed and accel must be finite and > 0")
        if len(start_ned) != 3 or not all(math.isfinite(c) for c in start_ned):
            raise ValueError("start_ned: expected 3 finite numbers N E D")
        self.sysid, self.compid, self.autopilot = sysid, compid, autopilot
        self.max_speed, self.max_accel = float(max_speed), float(max_accel)
        self.offboard_timeout_s = offboard_timeout_s
        self._link = Link(listen, sysid, compid)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._radio = True
        self._boot = time.monotonic()
        self._pos = [float(c) for c in start_ned]
        self._vel = [0.0, 0.0, 0.0]
        self._ground_d = max(0.0, float(start_ned[2]))
        self._home_d = self._ground_d
        self._px4 = autopilot == "px4"
        self._armed = airborne
        self._mode = ("OFFBOARD" if self._px4 else "GUIDED") if airborne else (
            "POSCTL" if self._px4 else "STABILIZE")
        self._hold = list(self._pos)  # where hold / loiter / guided-without-target stays
        self._target_pos: list[float] | None = None
        self._target_vel: list[float] | None = None
        self._target_time = 0.0
        self._takeoff_d: float | None = None
        self._stream_start: float | None = None
        self._last_setpoint: float | None = None
        self._position_interval = 0.1
        self.setpoints_accepted = 0
        self.setpoints_rejected = 0
        self.commands: list[tuple[int, int]] = []  # (command, result) answered, in order

    # ------------------------------------------------------------------------- public API
    @property
    def port(self) -> int | None:
        """Local UDP/TCP port of the link (useful with `udpin:127.0.0.1:0`)."""
        return self._link.local_port()

    @property
    def position_ned(self) -> tuple[float, float, float]:
        with self._lock:
            return tuple(self._pos)

    @property
    def velocity_ned(self) -> tuple[float, float, float]:
        with self._lock:
            return tuple(self._vel)

    @property
    def mode(self) -> str:
        with self._lock:
            return self._mode

    @property
    def armed(self) -> bool:
        with self._lock:
            return self._armed

    @property
    def landed(self) -> bool:
        with self._lock:
            return self._on_ground()

    @property
    def stats(self) -> LinkStats:
        with self._lock:
            return replace(self._link.stats)

    def set_radio(self, on: bool) -> None:
        """Switch the radio: when off, nothing is sent and everything received is dropped."""
        with self._lock:
            self._radio = on

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self.run, name=f"sim-vehicle-{self.sysid}",
                                            daemon=True)
            self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        self._link.close()

    def __enter__(self) -> SimVehicle:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def run(self, stop: threading.Event | None = None) -> None:
        """The vehicle loop; returns when `stop` (or `self.stop()`) is set."""
        stop = stop or self._stop
        dt = 1.0 / PHYSICS_HZ
        now = time.monotonic()
        next_tick, next_heartbeat, next_position = now, now, now
        fd = self._link.fileno()
        while not stop.is_set() and not self._stop.is_set():
            wait = max(0.0, next_tick - time.monotonic())
            if fd is None:
                time.sleep(min(wait, 0.01))
            else:
                try:
                    select.select([fd], [], [], wait)
                except (OSError, ValueError):
                    time.sleep(min(wait, 0.01))
            with self._lock:
                now = time.monotonic()
                for msg in self._link.poll():
                    if self._radio:
                        self._handle(msg, now)
                if now >= next_tick:
                    self._physics(min(now - next_tick + dt, 0.1), now)
                    next_tick = max(next_tick + dt, now)
                if now >= next_heartbeat:
                    self._send_heartbeat()
                    next_heartbeat = max(next_heartbeat + 1.0, now)
                if self._position_interval > 0 and now >= next_position:
                    self._send_position(now)
                    next_position = max(next_position + self._position_interval, now)

    # --------------------------------------------------------------------- MAVLink in/out
    def _send(self, msg: MAV.MAVLink_message) -> None:
        if self._radio:
            self._link.send(msg)

    def _boot_ms(self, now: float) -> int:
        return int((now - self._boot) * 1000.0) & 0xFFFFFFFF

    def _send_heartbeat(self) -> None:
        flags = MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        if self._armed:
            flags |= MAV.MAV_MODE_FLAG_SAFETY_ARMED
        if self._px4:
            custom, autopilot = px4_custom_mode(self._mode), MAV.MAV_AUTOPILOT_PX4
        else:
            custom, autopilot = COPTER_MODES[self._mode], MAV.MAV_AUTOPILOT_ARDUPILOTMEGA
            flags |= MAV.MAV_MODE_FLAG_STABILIZE_ENABLED
            if self._mode == "GUIDED":
                flags |= MAV.MAV_MODE_FLAG_GUIDED_ENABLED
        state = MAV.MAV_STATE_ACTIVE if self._armed and not self._on_ground() \
            else MAV.MAV_STATE_STANDBY
        self._send(self._link.mav.heartbeat_encode(MAV.MAV_TYPE_QUADROTOR, autopilot, flags,
                                                   custom, state))

    def _send_position(self, now: float) -> None:
        self._send(self._link.mav.local_position_ned_encode(self._boot_ms(now), *self._pos,
                                                            *self._vel))

    def _ack(self, msg: MAV.MAVLink_message, command: int, result: int) -> None:
        self.commands.append((command, result))
        self._send(self._link.mav.command_ack_encode(command, result, 0, 0,
                                                     msg.get_srcSystem(),
                                                     msg.get_srcComponent()))

    def _for_me(self, msg: MAV.MAVLink_message) -> bool:
        system = getattr(msg, "target_system", 0)
        component = getattr(msg, "target_component", 0)
        return system in (0, self.sysid) and component in (0, self.compid)

    def _handle(self, msg: MAV.MAVLink_message, now: float) -> None:
        kind = msg.get_type()
        if kind not in ("COMMAND_LONG", "COMMAND_INT", "SET_MODE",
                        "SET_POSITION_TARGET_LOCAL_NED") or not self._for_me(msg):
            return
        if kind == "SET_POSITION_TARGET_LOCAL_NED":
            self._on_setpoint(msg, now)
        elif kind == "SET_MODE":
            if not msg.base_mode & MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                self._ack(msg, MAV.MAVLINK_MSG_ID_SET_MODE, MAV.MAV_RESULT_UNSUPPORTED)
                return
            main, sub = (msg.custom_mode >> 16) & 0xFF, (msg.custom_mode >> 24) & 0xFF
            self._ack(msg, MAV.MAVLINK_MSG_ID_SET_MODE,
                      self._set_mode_number(msg.custom_mode, main, sub, now))
        elif kind == "COMMAND_INT":
            self._ack(msg, msg.command, MAV.MAV_RESULT_UNSUPPORTED)
        else:
            self._ack(msg, msg.command, self._command(msg, now))

    def _command(self, msg: MAV.MAVLink_message, now: float) -> int:
        c = msg.command
        if c == MAV.MAV_CMD_COMPONENT_ARM_DISARM:
            return self._arm(msg.param1 > 0.5, int(round(msg.param2)) == FORCE_DISARM_MAGIC, now)
        if c == MAV.MAV_CMD_DO_SET_MODE:
            if not int(msg.param1) & MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                return MAV.MAV_RESULT_UNSUPPORTED
            main, sub = int(msg.param2), int(msg.param3)
            return self._set_mode_number(int(msg.param2), main, sub, now)
        if c == MAV.MAV_CMD_NAV_TAKEOFF:
            return self._takeoff(msg.param7)
        if c == MAV.MAV_CMD_NAV_LAND:
            self._enter("LAND")
            return MAV.MAV_RESULT_ACCEPTED
        if c == MAV.MAV_CMD_SET_MESSAGE_INTERVAL:
            if int(msg.param1) != MAV.MAVLINK_MSG_ID_LOCAL_POSITION_NED:
                return MAV.MAV_RESULT_FAILED
            us = msg.param2
            self._position_interval = 0.1 if us == 0 else (0.0 if us < 0 else us * 1e-6)
            return MAV.MAV_RESULT_ACCEPTED
        return MAV.MAV_RESULT_UNSUPPORTED

    # --------------------------------------------------------------------- modes, arming
    def _on_ground(self) -> bool:
        return self._pos[2] >= self._ground_d - 0.05 and self._vel[2] >= -0.05

    def _streaming(self, now: float) -> bool:
        return (self._last_setpoint is not None
                and now - self._last_setpoint <= self.offboard_timeout_s
                and now - self._stream_start > PX4_STREAM_REQUIRED_S)

    def _enter(self, mode: str) -> None:
        self._mode = mode
        self._hold = list(self._pos)
        if mode == "LAND":
            self._takeoff_d = None

    def _set_mode_number(self, custom: int, main: int, sub: int, now: float) -> int:
        if self._px4:
            names = [n for n, (m, s) in PX4_MODES.items() if m == main and (s == sub or m != 4)]
            if not names:
                return MAV.MAV_RESULT_UNSUPPORTED
            name = names[0]
            if name == "OFFBOARD":
                if not self._streaming(now):
                    return MAV.MAV_RESULT_TEMPORARILY_REJECTED
                self._target_time = now
            elif name == "TAKEOFF":
                return self._takeoff(float("nan"))
        else:
            names = [n for n, number in COPTER_MODES.items() if number == custom]
            if not names:
                return MAV.MAV_RESULT_FAILED
            name = names[0]
            self._target_pos = self._target_vel = None  # a new GUIDED session: no target
        self._enter(name)
        return MAV.MAV_RESULT_ACCEPTED

    def _arm(self, arm: bool, force: bool, now: float) -> int:
        if arm:
            if self._px4 and self._mode == "OFFBOARD" and not self._streaming(now):
                return MAV.MAV_RESULT_DENIED
            if not self._armed:
                self._home_d = self._pos[2]
            self._armed = True
            return MAV.MAV_RESULT_ACCEPTED
        if not self._on_ground() and not force:
            return MAV.MAV_RESULT_DENIED if self._px4 else MAV.MAV_RESULT_FAILED
        self._armed = False
        return MAV.MAV_RESULT_ACCEPTED

    def _takeoff(self, altitude: float) -> int:
        if not self._armed:
            return MAV.MAV_RESULT_DENIED if self._px4 else MAV.MAV_RESULT_FAILED
        if self._px4:
            # PX4's param7 is AMSL; the sim's home is at 0 m AMSL, so it is the height.
            height = PX4_DEFAULT_TAKEOFF_M if math.isnan(altitude) else altitude
            self._enter("TAKEOFF")
        else:
            if self._mode != "GUIDED" or not self._on_ground() or not altitude > 0:
                return MAV.MAV_RESULT_FAILED
            height = altitude
        self._takeoff_d = self._home_d - height
        self._hold = [self._pos[0], self._pos[1], self._takeoff_d]
        return MAV.MAV_RESULT_ACCEPTED

    def _on_setpoint(self, msg: MAV.MAVLink_message, now: float) -> None:
        frames = PX4_FRAMES if self._px4 else ARDUPILOT_FRAMES
        mask = msg.type_mask
        pos_bits, vel_bits = mask & POS_BITS, mask & VEL_BITS
        use_pos, use_vel = pos_bits == 0, vel_bits == 0
        valid_groups = pos_bits in (0, POS_BITS) and vel_bits in (0, VEL_BITS)
        if msg.coordinate_frame not in frames or not valid_groups or not (use_pos or use_vel):
            self.setpoints_rejected += 1
            return
        if not self._px4 and self._mode != "GUIDED":
            self.setpoints_rejected += 1  # ArduPilot ignores targets outside GUIDED
            return
        position = [msg.x, msg.y, msg.z]
        if msg.coordinate_frame != MAV.MAV_FRAME_LOCAL_NED:  # offsets from where we are
            position = [p + o for p, o in zip(self._pos, position, strict=True)]
        self._target_pos = position if use_pos else None
        self._target_vel = [msg.vx, msg.vy, msg.vz] if use_vel else None
        self._target_time = now
        if self._last_setpoint is None or now - self._last_setpoint > self.offboard_timeout_s:
            self._stream_start = now
        self._last_setpoint = now
        self.setpoints_accepted += 1

    # ------------------------------------------------------------------------- dynamics
    def _goal(self, now: float) -> tuple[list[float] | None, list[float]]:
        """(position to reach or None, feed-forward velocity) for the current mode."""
        zero = [0.0, 0.0, 0.0]
        if not self._armed:
            return None, zero
        if self._mode == "LAND":
            if self._on_ground():
                self._armed = False
                return None, zero
            return None, [0.0, 0.0, LAND_SPEED]
        if self._mode == "OFFBOARD":
            # (--airborne starts in OFFBOARD with no stream yet; the loss needs a stream)
            if self._last_setpoint is not None and \
                    now - self._last_setpoint > self.offboard_timeout_s:
                self._enter("HOLD")  # PX4's offboard-loss failsafe without RC
                return self._hold, zero
        elif self._mode == "GUIDED":
            if self._takeoff_d is not None and self._target_pos is None and \
                    self._target_vel is None:
                return self._hold, zero
            if self._on_ground() and self._takeoff_d is None:
                return None, zero  # ArduCopter: landed, needs NAV_TAKEOFF first
            if self._target_pos is None and self._target_vel is not None and \
                    now - self._target_time > ARDUPILOT_VELOCITY_TIMEOUT_S:
                self._target_vel = None
                self._hold = list(self._pos)
            if self._target_pos is None and self._target_vel is None:
                return self._hold, zero
        elif self._mode == "TAKEOFF":
            if abs(self._pos[2] - self._takeoff_d) < 0.2:
                self._enter("HOLD")
            return self._hold, zero
        else:
            return self._hold, zero
        if self._target_pos is None and self._target_vel is None:
            return list(self._pos), zero
        return self._target_pos, (self._target_vel or zero)

    def _physics(self, dt: float, now: float) -> None:
        goal, ff = self._goal(now)
        if goal is None and not any(ff):
            desired = [0.0, 0.0, 0.0]
        else:
            desired = list(ff)
            if goal is not None:
                err = [g - p for g, p in zip(goal, self._pos, strict=True)]
                dist = math.sqrt(sum(e * e for e in err))
                if dist > 1e-9:
                    # slow down early enough to stop at the goal with half the accel limit
                    speed = min(self.max_speed, KP * dist, math.sqrt(self.max_accel * dist))
                    desired = [d + e / dist * speed for d, e in zip(desired, err, strict=True)]
        norm = math.sqrt(sum(d * d for d in desired))
        if norm > self.max_speed:
            desired = [d * self.max_speed / norm for d in desired]
        dv = [d - v for d, v in zip(desired, self._vel, strict=True)]
        dv_norm = math.sqrt(sum(c * c for c in dv))
        limit = self.max_accel * dt
        if dv_norm > limit:
            dv = [c * limit / dv_norm for c in dv]
        self._vel = [v + c for v, c in zip(self._vel, dv, strict=True)]
        self._pos = [p + v * dt for p, v in zip(self._pos, self._vel, strict=True)]
        if self._pos[2] > self._ground_d:  # the ground stops us
            self._pos[2] = self._ground_d
            self._vel[2] = min(self._vel[2], 0.0)
            if not self._armed:
                self._vel = [0.0, 0.0, 0.0]


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="uav-insar-vehicle",
        description="A SITL-style MAVLink multicopter (ArduPilot-like or PX4-like).")
    p.add_argument("--sysid", type=int, required=True, help="MAVLink system id, 1..255")
    p.add_argument("--listen", required=True,
                   help="pymavlink connection string, e.g. udpin:127.0.0.1:14552 (wait for "
                        "the bridge) or udpout:127.0.0.1:14550 (talk to it)")
    p.add_argument("--autopilot", choices=AUTOPILOTS, default="ardupilot",
                   help="heartbeat, modes and command semantics to imitate")
    p.add_argument("--start-ned", type=float, nargs=3, metavar=("N", "E", "D"),
                   default=(0.0, 0.0, 0.0), help="initial position in local NED [m]")
    p.add_argument("--speed", type=float, default=10.0, help="maximum speed [m/s]")
    p.add_argument("--accel", type=float, default=5.0, help="maximum acceleration [m/s^2]")
    p.add_argument("--airborne", action="store_true",
                   help="start armed and flying in GUIDED (ardupilot) or OFFBOARD (px4)")
    p.add_argument("--offboard-timeout", type=float, default=0.5,
                   help="PX4: leave OFFBOARD after this long without setpoints [s]")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run one vehicle until SIGINT / SIGTERM; 2 on bad arguments, 0 on a clean stop."""
    args = build_parser().parse_args(argv)
    try:
        vehicle = SimVehicle(args.sysid, args.listen, args.autopilot, tuple(args.start_ned),
                             args.speed, args.accel, args.airborne, args.offboard_timeout)
    except ValueError as exc:
        print(f"uav-insar-vehicle: error: {exc}", file=sys.stderr)
        return 2
    import signal

    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    print(f"vehicle sysid {args.sysid} ({args.autopilot}) on {args.listen}", flush=True)
    try:
        vehicle.run(stop)
    finally:
        vehicle.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
