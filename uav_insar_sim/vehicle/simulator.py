"""A SITL-style MAVLink multicopter: enough of ArduCopter or PX4 for the bridge and a GCS.

Command line (vehicle/cli.py: the `uav-insar-vehicle` console script, or
`python -m uav_insar_sim.vehicle`):

    uav-insar-vehicle --sysid 2 --listen udpin:127.0.0.1:14552 [--autopilot ardupilot|px4]
                      [--start-ned N E D] [--speed 10] [--accel 5] [--airborne]
                      [--boot-s 3] [--home LAT,LON,ALT] [--gcs-sysid 255]
                      [--signing-key-file FILE] [--position-noise-std M]
                      [--position-noise-tau S] [--noise-seed N] [--wind-mps N E D]

In-process (a background thread; what tests and an agent node use):

    with SimVehicle(sysid=2, listen="udpin:127.0.0.1:0", autopilot="px4") as vehicle:
        port = vehicle.port              # the bound UDP port (0 picks a free one)
        vehicle.position_ned             # (N, E, D) in metres, thread-safe snapshot
        vehicle.reported_position_ned    # what its telemetry says (estimate_error)
        vehicle.mode, vehicle.armed, vehicle.landed, vehicle.booted
        vehicle.set_radio(False)         # drop all traffic both ways (a link loss)

In-process the boot phase defaults to 0 s (`boot_s`), on the command line to 3 s; a vehicle
started `airborne` never boots. The MAVLink side, like the real autopilots (flight logic:
`autopilot.Autopilot`, telemetry: `telemetry`, parameters: `parameters`, commands:
`commands`, what differs per flavour: `profiles`; the loop's thread: `mavlink.io_thread`):
- Sent as (sysid, compid 1): HEARTBEAT (MAV_TYPE_QUADROTOR; ArduCopter mode numbers or PX4
  main << 16 | sub << 24), SYS_STATUS, GPS_RAW_INT, ATTITUDE, LOCAL_POSITION_NED,
  GLOBAL_POSITION_INT, HOME_POSITION, EXTENDED_SYS_STATE, BATTERY_STATUS at the
  `telemetry.DEFAULT_INTERVALS` rates; AUTOPILOT_VERSION and GPS_GLOBAL_ORIGIN on request;
  STATUSTEXT for refused arming. No position, home or origin before the boot phase ends.
- Obeyed only from the ground station `gcs_sysid` (default 255; 0 = anyone): COMMAND_LONG and
  COMMAND_INT (see `commands`), SET_MODE, SET_POSITION_TARGET_LOCAL_NED (frames LOCAL_NED,
  LOCAL_OFFSET_NED, BODY_NED, BODY_OFFSET_NED for ArduPilot, LOCAL_NED and BODY_NED for PX4;
  a mask of 0 uses every field; non-finite used fields are refused and counted), PARAM_SET,
  a mission upload (MISSION_COUNT, MISSION_ITEM_INT, MISSION_CLEAR_ALL: `mission_upload`,
  stored in `mission.items`, not flown). Answered from anyone: PARAM_REQUEST_LIST,
  PARAM_REQUEST_READ (PARAM_VALUE), MISSION_REQUEST_LIST / MISSION_REQUEST_INT (download).
- Messages for another system or component are ignored; a malformed one never stops it.
- Drops are counted in `stats` (link.LinkStats) and, on the command line, logged to stderr
  once per kind every 10 s (`guard.DropLog`): `foreign` (an obeyed message not from
  `gcs_sysid`), `bad_value` (a used setpoint field that is not finite, a command parameter
  that is NaN where required, infinite or out of range, which is ACKed DENIED, a PARAM_SET
  value that is not a number of its type) and, with `signing_key`, `bad_signature`.
- With `signing_key` (CLI `--signing-key-file`) everything sent is signed and only correctly
  signed frames are read (`signing`), from anyone: the GCS sysid rule still applies.
- Field conditions (off by default): `position_noise_std_m` / `position_noise_tau_s` /
  `noise_seed`, the reported position's wandering error (`estimate_error`); `wind_ned`, a
  steady wind its position controller fights (`autopilot`).
- If the vehicle loop dies, `failure` says why and the loop ends; the command line then
  prints one line and exits with exit_codes.EXIT_CRASH.
"""
from __future__ import annotations

import select
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import replace

from uav_insar_planner.mavlink.guard import DropLog, finite
from uav_insar_planner.mavlink.io_thread import IoThread
from uav_insar_planner.mavlink.link import MAV, Link, LinkStats
from uav_insar_planner.mavlink.sequencer import command_name
from uav_insar_planner.mavlink.setpoints import used_values
from uav_insar_planner.mavlink.signing import signing_state
from uav_insar_sim.vehicle import estimate_error
from uav_insar_sim.vehicle.autopilot import Autopilot
from uav_insar_sim.vehicle.commands import run_command
from uav_insar_sim.vehicle.mission_upload import MissionStore
from uav_insar_sim.vehicle.parameters import ParamTable
from uav_insar_sim.vehicle.telemetry import SITL_HOME, Streams, Telemetry

__all__ = ["SimVehicle"]

PHYSICS_HZ = 50.0
MAX_COMMANDS_KEPT = 1000
MISSION_IN = frozenset(("MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_CLEAR_ALL",
                        "MISSION_REQUEST_LIST", "MISSION_REQUEST_INT"))
OBEYED = frozenset(("COMMAND_LONG", "COMMAND_INT", "SET_MODE",
                    "SET_POSITION_TARGET_LOCAL_NED", "PARAM_SET", "MISSION_COUNT",
                    "MISSION_ITEM_INT", "MISSION_CLEAR_ALL"))
HANDLED = OBEYED | MISSION_IN | {"PARAM_REQUEST_LIST", "PARAM_REQUEST_READ"}


class SimVehicle(IoThread):
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
                 gcs_sysid: int = 255, signing_key: bytes | None = None,
                 log: Callable[[str], None] | None = None,
                 position_noise_std_m: float = 0.0,
                 position_noise_tau_s: float = estimate_error.DEFAULT_TAU_S,
                 noise_seed: int = 0, wind_ned: tuple[float, float, float] = (0.0, 0.0, 0.0)):
        if not 1 <= sysid <= 255:
            raise ValueError(f"sysid: {sysid!r} is not allowed; expected 1..255")
        if not 0 <= gcs_sysid <= 255:
            raise ValueError(f"gcs_sysid: {gcs_sysid!r} is not allowed; expected 0..255")
        super().__init__(f"sim-vehicle-{sysid}")
        self.sysid, self.compid, self.autopilot = sysid, compid, autopilot
        self.gcs_sysid = int(gcs_sysid)
        self._boot = time.monotonic()
        self._ap = Autopilot(autopilot, start_ned, max_speed, max_accel, airborne,
                             offboard_timeout_s, boot_s, self._boot, wind_ned)
        error = estimate_error.EstimateError(position_noise_std_m, position_noise_tau_s,
                                             noise_seed, sysid)
        signing = None if signing_key is None else signing_state(signing_key, link_id=0)
        self._link = Link(listen, sysid, compid, signing)
        self._drops = DropLog()
        self._log = log
        #: why the vehicle loop died (None while it runs or never ran)
        self.failure: str | None = None
        self.telemetry = Telemetry(self._link.mav, self._ap, tuple(home), self._boot, sysid,
                                   error)
        self.streams = Streams()
        self.params = ParamTable(self._ap.profile.params(self),
                                 bytewise=self._ap.profile.bytewise_params)
        self._lock = threading.Lock()
        self._radio = True
        #: the last MAX_COMMANDS_KEPT (command, result) answered, in order (bounded: a flood
        #: of commands must not grow memory)
        self.commands: deque[tuple[int, int]] = deque(maxlen=MAX_COMMANDS_KEPT)
        self.errors = 0  # messages whose handling raised (answered FAILED, never fatal)
        self.mission = MissionStore()  # accepted and stored, not flown
        #: (UTC arrival [s], first item, MAV_RESULT) of each MISSION_START, bounded as `commands`
        self.mission_starts: deque[tuple[float, int, int]] = deque(maxlen=MAX_COMMANDS_KEPT)

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
    def reported_position_ned(self) -> tuple[float, float, float]:
        """The position its telemetry reports: position_ned off by the estimate's error."""
        with self._lock:
            return self.telemetry.position()

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

    @property
    def alive(self) -> bool:
        """True while the background thread runs and has not failed."""
        return self.thread_alive and self.failure is None

    def close(self) -> None:
        self._link.close()

    def run(self, stop: threading.Event | None = None) -> None:
        """The vehicle loop; returns when `stop` (or `self.stop()`) is set, or when the loop
        failed: then `failure` says why (logged through `log`), never silently."""
        try:
            self._loop(stop)
        except Exception as exc:  # recorded: whoever runs the vehicle must stop too
            self.failure = f"{type(exc).__name__}: {str(exc)[:200]}"
            if self._log is not None:
                self._log(f"sysid {self.sysid}: vehicle loop died: {self.failure}")

    def _loop(self, stop: threading.Event | None) -> None:
        dt = 1.0 / PHYSICS_HZ
        next_tick = time.monotonic()
        fd = self._link.fileno()
        while not self.stopping and not (stop is not None and stop.is_set()):
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
        self._send(self.telemetry.heartbeat(time.monotonic()))

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
        except Exception as exc:  # noqa: BLE001 - a GCS must never be able to stop the vehicle
            self.errors += 1
            line = self._drops.drop("message whose handling raised",
                                    f"{msg.get_type()}: {type(exc).__name__}: {exc}")
            if line is not None and self._log is not None:
                self._log(f"sysid {self.sysid}: {line}")
            if msg.get_type() in ("COMMAND_LONG", "COMMAND_INT"):
                self._ack(msg, msg.command, MAV.MAV_RESULT_FAILED)

    def _drop(self, counter: str, detail: str) -> None:
        """Count a dropped / refused message; log it at a bounded rate."""
        setattr(self._link.stats, counter, getattr(self._link.stats, counter) + 1)
        line = self._drops.drop(counter, detail)
        if line is not None and self._log is not None:
            self._log(f"sysid {self.sysid}: {line}")

    def _handle(self, msg: MAV.MAVLink_message, now: float) -> None:
        kind = msg.get_type()
        if kind not in HANDLED or not self._for_me(msg):
            return
        src = msg.get_srcSystem()
        if kind in OBEYED and self.gcs_sysid not in (0, src):
            # only the configured ground station commands this vehicle
            self._drop("foreign", f"{kind} from sysid {src}, not the GCS {self.gcs_sysid}")
            return
        if kind in MISSION_IN:
            for reply in self.mission.handle(self._link.mav, msg):
                self._send(reply)
        elif kind == "SET_POSITION_TARGET_LOCAL_NED":
            position, velocity = (msg.x, msg.y, msg.z), (msg.vx, msg.vy, msg.vz)
            if not finite(used_values(msg.type_mask, position, velocity)):
                self._drop("bad_value", f"setpoint with a used field not finite: position "
                                        f"{position}, velocity {velocity}")
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
            self._command(msg, (msg.param1, msg.param2, msg.param3, msg.param4, msg.x, msg.y,
                                msg.z), now)
        elif kind == "COMMAND_LONG":
            self._command(msg, (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5,
                                msg.param6, msg.param7), now)
        elif kind == "PARAM_REQUEST_LIST":
            for i in range(len(self.params)):
                self._send_param(i)
        elif kind == "PARAM_REQUEST_READ":
            i = self.params.find(_param_name(msg.param_id), msg.param_index)
            if i is not None:
                self._send_param(i)
        else:  # PARAM_SET
            if self.params.decode(msg.param_value, msg.param_type) is None:
                self._drop("bad_value", f"PARAM_SET {_param_name(msg.param_id)!r} = "
                                        f"{msg.param_value!r}")
            i = self.params.set(_param_name(msg.param_id), msg.param_value, msg.param_type)
            if i is not None:
                self._send_param(i)

    def _command(self, msg: MAV.MAVLink_message, params: tuple, now: float) -> None:
        result, problem = run_command(self, msg.command, params, now)
        if problem:
            self._drop("bad_value", f"{command_name(msg.command)}: {problem}; DENIED")
        self._ack(msg, msg.command, result)


def _param_name(param_id: str | bytes) -> str:
    if isinstance(param_id, bytes):
        param_id = param_id.decode("ascii", "replace")
    return param_id.rstrip("\x00")
