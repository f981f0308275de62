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

The MAVLink side, like the real autopilots (the flight logic is `autopilot.Autopilot`):
- HEARTBEAT at 1 Hz as (sysid, compid 1), MAV_TYPE_QUADROTOR, autopilot ARDUPILOTMEGA with
  Copter mode numbers (STABILIZE 0, GUIDED 4, LOITER 5, LAND 9) or PX4 with
  custom_mode = main << 16 | sub << 24 (POSCTL, OFFBOARD, AUTO.TAKEOFF/LOITER/LAND).
- LOCAL_POSITION_NED at 10 Hz (MAV_CMD_SET_MESSAGE_INTERVAL changes it).
- COMMAND_LONG ARM_DISARM, DO_SET_MODE, NAV_TAKEOFF, NAV_LAND, SET_MESSAGE_INTERVAL and the
  SET_MODE message are answered with COMMAND_ACK; other commands get UNSUPPORTED.
- SET_POSITION_TARGET_LOCAL_NED: frames LOCAL_NED, LOCAL_OFFSET_NED, BODY_NED,
  BODY_OFFSET_NED for ArduPilot, LOCAL_NED and BODY_NED for PX4 (others are rejected and
  counted); acceleration fields are ignored. A mask of 0 means "use every field", so
  x = y = z = 0 flies the vehicle to the origin, just as on the real thing.
- Messages for another system or component are ignored.
"""
from __future__ import annotations

import argparse
import select
import sys
import threading
import time
from dataclasses import replace

from uav_insar_planner.mavlink.autopilots import AUTOPILOTS, COPTER_MODES, px4_custom_mode
from uav_insar_planner.mavlink.link import MAV, Link, LinkStats
from uav_insar_sim.autopilot import Autopilot

__all__ = ["SimVehicle", "build_parser", "main"]

PHYSICS_HZ = 50.0
FORCE_DISARM_MAGIC = 21196


class SimVehicle:
    """One simulated multicopter on one MAVLink endpoint (see the module doc for behaviour).

    The constructor opens the link (ValueError if it or an argument is bad); `start()` runs
    the vehicle in a daemon thread, `stop()` ends it and closes the link; `run(stop_event)`
    runs in the calling thread instead (the CLI). Properties are thread-safe snapshots.
    """

    def __init__(self, sysid: int, listen: str, autopilot: str = "ardupilot",
                 start_ned: tuple[float, float, float] = (0.0, 0.0, 0.0),
                 max_speed: float = 10.0, max_accel: float = 5.0, airborne: bool = False,
                 offboard_timeout_s: float = 0.5, compid: int = MAV.MAV_COMP_ID_AUTOPILOT1):
        if not 1 <= sysid <= 255:
            raise ValueError(f"sysid: {sysid!r} is not allowed; expected 1..255")
        self.sysid, self.compid, self.autopilot = sysid, compid, autopilot
        self._ap = Autopilot(autopilot, start_ned, max_speed, max_accel, airborne,
                             offboard_timeout_s)
        self._link = Link(listen, sysid, compid)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._radio = True
        self._boot = time.monotonic()
        self._position_interval = 0.1
        self.commands: list[tuple[int, int]] = []  # (command, result) answered, in order

    # ------------------------------------------------------------------------- public API
    @property
    def port(self) -> int | None:
        """Local UDP/TCP port of the link (useful with `udpin:127.0.0.1:0`)."""
        return self._link.local_port()

    @property
    def position_ned(self) -> tuple[float, float, float]:
        with self._lock:
            return self._ap.position

    @property
    def velocity_ned(self) -> tuple[float, float, float]:
        with self._lock:
            return self._ap.velocity

    @property
    def mode(self) -> str:
        with self._lock:
            return self._ap.mode

    @property
    def armed(self) -> bool:
        with self._lock:
            return self._ap.armed

    @property
    def landed(self) -> bool:
        with self._lock:
            return self._ap.on_ground()

    @property
    def setpoints_accepted(self) -> int:
        return self._ap.setpoints_accepted

    @property
    def setpoints_rejected(self) -> int:
        return self._ap.setpoints_rejected

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
                    self._ap.tick(min(now - next_tick + dt, 0.1), now)
                    next_tick = max(next_tick + dt, now)
                if now >= next_heartbeat:
                    self._send_heartbeat()
                    next_heartbeat = max(next_heartbeat + 1.0, now)
                if self._position_interval > 0 and now >= next_position:
                    self._send_position(now)
                    next_position = max(next_position + self._position_interval, now)

    # --------------------------------------------------------------------- MAVLink out
    def _send(self, msg: MAV.MAVLink_message) -> None:
        if self._radio:
            self._link.send(msg)

    def _send_heartbeat(self) -> None:
        ap = self._ap
        flags = MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        if ap.armed:
            flags |= MAV.MAV_MODE_FLAG_SAFETY_ARMED
        if ap.px4:
            custom, autopilot = px4_custom_mode(ap.mode), MAV.MAV_AUTOPILOT_PX4
        else:
            custom, autopilot = COPTER_MODES[ap.mode], MAV.MAV_AUTOPILOT_ARDUPILOTMEGA
            flags |= MAV.MAV_MODE_FLAG_STABILIZE_ENABLED
            if ap.mode == "GUIDED":
                flags |= MAV.MAV_MODE_FLAG_GUIDED_ENABLED
        state = MAV.MAV_STATE_ACTIVE if ap.armed and not ap.on_ground() \
            else MAV.MAV_STATE_STANDBY
        self._send(self._link.mav.heartbeat_encode(MAV.MAV_TYPE_QUADROTOR, autopilot, flags,
                                                   custom, state))

    def _send_position(self, now: float) -> None:
        boot_ms = int((now - self._boot) * 1000.0) & 0xFFFFFFFF
        self._send(self._link.mav.local_position_ned_encode(boot_ms, *self._ap.position,
                                                            *self._ap.velocity))

    def _ack(self, msg: MAV.MAVLink_message, command: int, result: int) -> None:
        self.commands.append((command, result))
        self._send(self._link.mav.command_ack_encode(command, result, 0, 0,
                                                     msg.get_srcSystem(),
                                                     msg.get_srcComponent()))

    # --------------------------------------------------------------------- MAVLink in
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
            self._ap.setpoint(msg.coordinate_frame, msg.type_mask, (msg.x, msg.y, msg.z),
                              (msg.vx, msg.vy, msg.vz), now)
        elif kind == "SET_MODE":
            if not msg.base_mode & MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                self._ack(msg, MAV.MAVLINK_MSG_ID_SET_MODE, MAV.MAV_RESULT_UNSUPPORTED)
                return
            main, sub = (msg.custom_mode >> 16) & 0xFF, (msg.custom_mode >> 24) & 0xFF
            self._ack(msg, MAV.MAVLINK_MSG_ID_SET_MODE,
                      self._ap.set_mode(msg.custom_mode, main, sub, now))
        elif kind == "COMMAND_INT":
            self._ack(msg, msg.command, MAV.MAV_RESULT_UNSUPPORTED)
        else:
            self._ack(msg, msg.command, self._command(msg, now))

    def _command(self, msg: MAV.MAVLink_message, now: float) -> int:
        c = msg.command
        if c == MAV.MAV_CMD_COMPONENT_ARM_DISARM:
            return self._ap.arm(msg.param1 > 0.5, int(round(msg.param2)) == FORCE_DISARM_MAGIC,
                                now)
        if c == MAV.MAV_CMD_DO_SET_MODE:
            if not int(msg.param1) & MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                return MAV.MAV_RESULT_UNSUPPORTED
            return self._ap.set_mode(int(msg.param2), int(msg.param2), int(msg.param3), now)
        if c == MAV.MAV_CMD_NAV_TAKEOFF:
            return self._ap.takeoff(msg.param7)
        if c == MAV.MAV_CMD_NAV_LAND:
            return self._ap.land()
        if c == MAV.MAV_CMD_SET_MESSAGE_INTERVAL:
            if int(msg.param1) != MAV.MAVLINK_MSG_ID_LOCAL_POSITION_NED:
                return MAV.MAV_RESULT_FAILED
            us = msg.param2
            self._position_interval = 0.1 if us == 0 else (0.0 if us < 0 else us * 1e-6)
            return MAV.MAV_RESULT_ACCEPTED
        return MAV.MAV_RESULT_UNSUPPORTED


# ----------------------------------------------------------------------------- command line
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
