"""A SITL-style MAVLink multicopter: enough of ArduCopter or PX4 for the bridge and a GCS.

Command line (the `uav-insar-vehicle` console script, or `python -m uav_insar_sim.vehicle`):

    uav-insar-vehicle --sysid 2 --listen udpin:127.0.0.1:14552 [--autopilot ardupilot|px4]
                      [--start-ned N E D] [--speed 10] [--accel 5] [--airborne]
                      [--boot-s 3] [--home LAT,LON,ALT] [--gcs-sysid 255]

In-process (a background thread; what tests and an agent node use):

    with SimVehicle(sysid=2, listen="udpin:127.0.0.1:0", autopilot="px4") as vehicle:
        port = vehicle.port              # the bound UDP port (0 picks a free one)
        vehicle.position_ned             # (N, E, D) in metres, thread-safe snapshot
        vehicle.mode, vehicle.armed, vehicle.landed, vehicle.booted
        vehicle.set_radio(False)         # drop all traffic both ways (a link loss)

In-process the boot phase defaults to 0 s (`boot_s`), on the command line to 3 s; a vehicle
started `airborne` never boots. The MAVLink side, like the real autopilots (flight logic:
`autopilot.Autopilot`, telemetry: `telemetry`, parameters: `sim_params`, commands:
`commands`):
- Sent as (sysid, compid 1): HEARTBEAT (MAV_TYPE_QUADROTOR; ArduCopter mode numbers or PX4
  main << 16 | sub << 24), SYS_STATUS, GPS_RAW_INT, ATTITUDE, LOCAL_POSITION_NED,
  GLOBAL_POSITION_INT, HOME_POSITION, EXTENDED_SYS_STATE, BATTERY_STATUS at the
  `telemetry.DEFAULT_INTERVALS` rates; AUTOPILOT_VERSION and GPS_GLOBAL_ORIGIN on request;
  STATUSTEXT for refused arming. No position, home or origin before the boot phase ends.
- Obeyed only from the ground station `gcs_sysid` (default 255; 0 = anyone): COMMAND_LONG and
  COMMAND_INT (see `commands`), SET_MODE, SET_POSITION_TARGET_LOCAL_NED (frames LOCAL_NED,
  LOCAL_OFFSET_NED, BODY_NED, BODY_OFFSET_NED for ArduPilot, LOCAL_NED and BODY_NED for PX4;
  a mask of 0 uses every field; non-finite used fields are refused and counted), PARAM_SET.
  Answered from anyone: PARAM_REQUEST_LIST, PARAM_REQUEST_READ (PARAM_VALUE).
- Messages for another system or component are ignored; a malformed one never stops it.
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
from uav_insar_sim.commands import run_command
from uav_insar_sim.sim_params import ParamTable, vehicle_params
from uav_insar_sim.telemetry import SITL_HOME, Streams, Telemetry, parse_home

__all__ = ["SimVehicle", "build_parser", "main"]

PHYSICS_HZ = 50.0
OBEYED = frozenset(("COMMAND_LONG", "COMMAND_INT", "SET_MODE",
                    "SET_POSITION_TARGET_LOCAL_NED", "PARAM_SET"))
HANDLED = OBEYED | {"PARAM_REQUEST_LIST", "PARAM_REQUEST_READ"}


class SimVehicle:
    """One simulated multicopter on one MAVLink endpoint (see the module doc for behaviour).

    The constructor opens the link (ValueError if it or an argument is bad); `start()` runs
    the vehicle in a daemon thread, `stop()` ends it and closes the link; `run(stop_event)`
    runs in the calling thread instead (the CLI). Properties are thread-safe snapshots.
    """

    def __init__(self, sysid: int, listen: str, autopilot: str = "ardupilot",
                 start_ned: tuple[float, float, float] = (0.0, 0.0, 0.0),
                 max_speed: float = 10.0, max_accel: float = 5.0, airborne: bool = False,
                 offboard_timeout_s: float = 0.5, compid: int = MAV.MAV_COMP_ID_AUTOPILOT1,
                 *, boot_s: float = 0.0, home: tuple[float, float, float] = SITL_HOME,
                 gcs_sysid: int = 255):
        if not 1 <= sysid <= 255:
            raise ValueError(f"sysid: {sysid!r} is not allowed; expected 1..255")
        if not 0 <= gcs_sysid <= 255:
            raise ValueError(f"gcs_sysid: {gcs_sysid!r} is not allowed; expected 0..255")
        self.sysid, self.compid, self.autopilot = sysid, compid, autopilot
        self.gcs_sysid = int(gcs_sysid)
        self._boot = time.monotonic()
        self._ap = Autopilot(autopilot, start_ned, max_speed, max_accel, airborne,
                             offboard_timeout_s, boot_s, self._boot)
        self._link = Link(listen, sysid, compid)
        self.telemetry = Telemetry(self._link.mav, self._ap, tuple(home), self._boot, sysid)
        self.streams = Streams()
        self.params = ParamTable(vehicle_params(self), bytewise=self._ap.px4)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._radio = True
        self.commands: list[tuple[int, int]] = []  # (command, result) answered, in order
        self.errors = 0  # messages whose handling raised (answered FAILED, never fatal)

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
    def booted(self) -> bool:
        with self._lock:
            return self._ap.booted(time.monotonic())

    @property
    def boot_remaining_s(self) -> float:
        """Seconds left of the boot phase (0 once booted)."""
        with self._lock:
            return max(0.0, self._ap.boot_end - time.monotonic())

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
        next_tick = time.monotonic()
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
                        self._handle_safely(msg, now)
                if now >= next_tick:
                    self._ap.tick(min(now - next_tick + dt, 0.1), now)
                    self.telemetry.update(now)
                    next_tick = max(next_tick + dt, now)
                for msgid in self.streams.due(now):
                    self.send_now(msgid, now)
                self._send_statustexts()

    # --------------------------------------------------------------------- MAVLink out
    def _send(self, msg: MAV.MAVLink_message) -> None:
        if self._radio:
            self._link.send(msg)

    def send_now(self, msgid: int, now: float) -> bool:
        """Send message `msgid` once; False when it is not available (yet)."""
        if msgid == MAV.MAVLINK_MSG_ID_HEARTBEAT:
            self._send_heartbeat()
            return True
        msg = self.telemetry.build(msgid, now, self._ap.booted(now))
        if msg is None:
            return False
        self._send(msg)
        return True

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
        if not ap.booted(time.monotonic()):
            state = MAV.MAV_STATE_BOOT if ap.px4 else MAV.MAV_STATE_CALIBRATING
        elif ap.armed and not ap.on_ground():
            state = MAV.MAV_STATE_ACTIVE
        else:
            state = MAV.MAV_STATE_STANDBY
        self._send(self._link.mav.heartbeat_encode(MAV.MAV_TYPE_QUADROTOR, autopilot, flags,
                                                   custom, state))

    def _send_statustexts(self) -> None:
        while self._ap.statustexts:
            severity, text = self._ap.statustexts.pop(0)
            self._send(self._link.mav.statustext_encode(severity, text.encode()[:50]))

    def _send_param(self, i: int) -> None:
        p = self.params.params[i]
        self._send(self._link.mav.param_value_encode(p.name.encode(), self.params.encode(i),
                                                     p.kind, len(self.params), i))

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

    def _handle_safely(self, msg: MAV.MAVLink_message, now: float) -> None:
        try:
            self._handle(msg, now)
        except Exception:  # noqa: BLE001 - a GCS must never be able to stop the vehicle
            self.errors += 1
            if msg.get_type() in ("COMMAND_LONG", "COMMAND_INT"):
                self._ack(msg, msg.command, MAV.MAV_RESULT_FAILED)

    def _handle(self, msg: MAV.MAVLink_message, now: float) -> None:
        kind = msg.get_type()
        if kind not in HANDLED or not self._for_me(msg):
            return
        if kind in OBEYED and self.gcs_sysid not in (0, msg.get_srcSystem()):
            return  # only the configured ground station commands this vehicle
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
            params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.x, msg.y, msg.z)
            self._ack(msg, msg.command, run_command(self, msg.command, params, now))
        elif kind == "COMMAND_LONG":
            params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5,
                      msg.param6, msg.param7)
            self._ack(msg, msg.command, run_command(self, msg.command, params, now))
        elif kind == "PARAM_REQUEST_LIST":
            for i in range(len(self.params)):
                self._send_param(i)
        elif kind == "PARAM_REQUEST_READ":
            i = self.params.find(_param_name(msg.param_id), msg.param_index)
            if i is not None:
                self._send_param(i)
        else:  # PARAM_SET
            i = self.params.set(_param_name(msg.param_id), msg.param_value, msg.param_type)
            if i is not None:
                self._send_param(i)


def _param_name(param_id: str | bytes) -> str:
    if isinstance(param_id, bytes):
        param_id = param_id.decode("ascii", "replace")
    return param_id.rstrip("\x00")


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
                   help="start armed and flying in GUIDED (ardupilot) or OFFBOARD (px4), "
                        "with no boot phase")
    p.add_argument("--offboard-timeout", type=float, default=0.5,
                   help="PX4: leave OFFBOARD after this long without setpoints [s]")
    p.add_argument("--boot-s", type=float, default=3.0,
                   help="boot phase: no position and arming refused for this long [s]")
    p.add_argument("--home", default=",".join(str(c) for c in SITL_HOME),
                   help="LAT,LON,ALT (deg, deg, m AMSL) of the local NED origin "
                        "(default: ArduPilot SITL's)")
    p.add_argument("--gcs-sysid", type=int, default=255,
                   help="the only ground-station sysid obeyed; 0 obeys anyone")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run one vehicle until SIGINT / SIGTERM; 2 on bad arguments, 0 on a clean stop."""
    args = build_parser().parse_args(argv)
    try:
        vehicle = SimVehicle(args.sysid, args.listen, args.autopilot, tuple(args.start_ned),
                             args.speed, args.accel, args.airborne, args.offboard_timeout,
                             boot_s=args.boot_s, home=parse_home(args.home),
                             gcs_sysid=args.gcs_sysid)
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
