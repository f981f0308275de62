"""The swarm bridge: formation in the track frame -> SET_POSITION_TARGET_LOCAL_NED per UAV.

Contract (DESIGN.md section 6, issue 4):
- One MAVLink link per distinct connection string; several UAVs may share one (a router),
  each addressed by its own sysid and the component its heartbeat came from (default 1).
- Setpoints in MAV_FRAME_LOCAL_NED at `setpoint_rate_hz` (2..50, default 10): type_mask
  3576 (position only) or 3520 (position + velocity feed-forward along the track).
- UAV k's target: (x_k, y_start, z_k) until the track starts, then
  (x_k, y_start + v (t - t_start), z_k); with `track_duration_s` > 0 it brakes to a stop
  exactly at y_start + v track_duration_s (`along_track`).
  The track starts (t_start) once every linked UAV with a target is within
  `capture_radius_m` of its start point (0: at once), so the formation is established before
  the pass; UAVs that are lost or whose arming failed do not hold the others back.
- Our HEARTBEAT at 1 Hz as (source_sysid, 191), MAV_TYPE_ONBOARD_CONTROLLER. A UAV is lost
  after `heartbeat_timeout_s` (5 s) without a vehicle heartbeat and found when one returns;
  setpoints to the others never stop, nor to the lost one (PX4 needs the stream on return).
- LOCAL_POSITION_NED is read back (and requested at 10 Hz with SET_MESSAGE_INTERVAL).
- Optional arm_and_takeoff: ArduPilot GUIDED -> arm -> NAV_TAKEOFF to the formation altitude,
  setpoints resume once the climb is done; PX4 streams setpoints > 1 s, then OFFBOARD -> arm
  (the offboard setpoint is the takeoff). Each COMMAND_ACK is checked and reported as an event.

All I/O runs in one background thread (`start()` / `stop()`); `set_formation`, `status`,
`link_stats` and `drain_events` are thread-safe and are what the ROS node calls.
"""
from __future__ import annotations

import math
import select
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

from pymavlink import mavutil

from uav_insar_planner.mavlink.frames import TrackFrame, Vec3
from uav_insar_planner.mavlink.link import MAV, Link, LinkStats, parse_address

AUTOPILOTS = ("ardupilot", "px4")
MASK_POSITION = 0x0DF8  # 3576: ignore velocity, acceleration, yaw, yaw rate
MASK_POSITION_VELOCITY = 0x0DC0  # 3520: position + velocity feed-forward
BRIDGE_COMPID = MAV.MAV_COMP_ID_ONBOARD_COMPUTER  # 191
COPTER_MODE_GUIDED = 4
PX4_MAIN_MODE_OFFBOARD = 6
POSITION_INTERVAL_US = 100_000  # ask for LOCAL_POSITION_NED at 10 Hz
PX4_STREAM_BEFORE_OFFBOARD_S = 1.2  # PX4 wants > 1 s of setpoints; margin for jitter
COMMAND_TIMEOUT_S = 1.0
COMMAND_ATTEMPTS = 3
TEMP_REJECT_ATTEMPTS = 5
CLIMB_TIMEOUT_EXTRA_S = 20.0
_NOT_VEHICLE_TYPES = frozenset((MAV.MAV_TYPE_GCS, MAV.MAV_TYPE_ONBOARD_CONTROLLER,
                                MAV.MAV_TYPE_GIMBAL, MAV.MAV_TYPE_ADSB, MAV.MAV_TYPE_CAMERA,
                                MAV.MAV_TYPE_ANTENNA_TRACKER))


def result_name(result: int) -> str:
    """MAV_RESULT number -> its short name (ACCEPTED, DENIED, ...)."""
    entry = MAV.enums["MAV_RESULT"].get(result)
    return entry.name.removeprefix("MAV_RESULT_") if entry else f"RESULT({result})"


def command_name(command: int) -> str:
    """MAV_CMD number -> its short name (COMPONENT_ARM_DISARM, ...)."""
    entry = MAV.enums["MAV_CMD"].get(command)
    return entry.name.removeprefix("MAV_CMD_") if entry else f"CMD({command})"


# Braking at the end of a finite pass, gentle for a multicopter's position controller.
BRAKE_MPS2 = 1.5


def along_track(elapsed: float, speed: float, duration: float) -> tuple[float, float]:
    """(offset, velocity) of the along-track target `elapsed` seconds into the pass.

    duration 0: cruise at `speed` for ever. Otherwise cruise, then brake at BRAKE_MPS2 (less
    for a short pass) so that the target stops exactly at speed * duration: a target that
    stopped dead would make every vehicle overshoot by v^2 / (2 a_max) and come back.
    """
    if duration <= 0.0:
        return speed * elapsed, speed
    if speed <= 0.0:
        return 0.0, 0.0
    brake_s = min(speed / BRAKE_MPS2, 2.0 * duration)
    decel = speed / brake_s
    t_brake = duration - brake_s / 2.0  # cruise + braking distances add up to speed * duration
    if elapsed <= t_brake:
        return speed * elapsed, speed
    tau = min(elapsed - t_brake, brake_s)
    return speed * t_brake + speed * tau - 0.5 * decel * tau * tau, speed - decel * tau


@dataclass(frozen=True)
class BridgeConfig:
    """Everything the bridge needs; SI inside, degrees only in `track_bearing_deg`."""

    connections: tuple[str, ...]
    target_sysids: tuple[int, ...]
    source_sysid: int = 255
    track_bearing_deg: float = 0.0
    origin_ned_m: Vec3 = (0.0, 0.0, 0.0)
    setpoint_rate_hz: float = 10.0
    velocity_feedforward: bool = False
    arm_and_takeoff: bool = False
    autopilot: str = "ardupilot"
    speed_mps: float = 4.3
    track_duration_s: float = 0.0
    capture_radius_m: float = 1.0
    heartbeat_timeout_s: float = 5.0

    def validate(self) -> None:
        """Raise ValueError with one line naming the first bad value and what is allowed."""
        n = len(self.target_sysids)
        if n == 0:
            raise ValueError("target_sysids: empty; expected one sysid (1..255) per UAV")
        if len(self.connections) not in (1, n):
            raise ValueError(f"connections: {len(self.connections)} given for {n} UAVs; "
                             "expected one per UAV in target_sysids, or one shared")
        for i, address in enumerate(self.connections):
            try:
                parse_address(address)
            except ValueError as exc:
                raise ValueError(f"connections[{i}]: {exc}") from None
        for sysid in (*self.target_sysids, self.source_sysid):
            if isinstance(sysid, bool) or not isinstance(sysid, int) or not 1 <= sysid <= 255:
                raise ValueError(f"sysid {sysid!r} is not allowed; expected an integer 1..255")
        if len(set(self.target_sysids)) != n:
            raise ValueError(f"target_sysids: {list(self.target_sysids)} repeats a sysid; "
                             "each UAV needs its own")
        if self.source_sysid in self.target_sysids:
            raise ValueError(f"source_sysid: {self.source_sysid} is also a target sysid; "
                             "expected the bridge's own id (e.g. 255, the SYSID_MYGCS default)")
        if self.autopilot not in AUTOPILOTS:
            raise ValueError(f"autopilot: {self.autopilot!r} is not allowed; expected one of "
                             + ", ".join(AUTOPILOTS))
        numbers = {"track_bearing_deg": self.track_bearing_deg,
                   "setpoint_rate_hz": self.setpoint_rate_hz, "speed_mps": self.speed_mps,
                   "track_duration_s": self.track_duration_s,
                   "capture_radius_m": self.capture_radius_m,
                   "heartbeat_timeout_s": self.heartbeat_timeout_s}
        for name, value in numbers.items():
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value):
                raise ValueError(f"{name}: value {value!r} is not allowed; expected a finite "
                                 "number")
        if len(self.origin_ned_m) != 3 or not all(
                isinstance(v, (int, float)) and math.isfinite(v) for v in self.origin_ned_m):
            raise ValueError(f"origin_ned_m: value {list(self.origin_ned_m)!r} is not allowed; "
                             "expected 3 finite numbers (N, E, D) in metres")
        if not 2.0 <= self.setpoint_rate_hz <= 50.0:
            raise ValueError(f"setpoint_rate_hz: value {self.setpoint_rate_hz!r} is not "
                             "allowed; expected 2..50 (PX4 leaves offboard below 2 Hz)")
        for name in ("speed_mps", "track_duration_s", "capture_radius_m"):
            if numbers[name] < 0.0:
                raise ValueError(f"{name}: value {numbers[name]!r} is not allowed; expected "
                                 ">= 0")
        if self.heartbeat_timeout_s <= 0.0:
            raise ValueError(f"heartbeat_timeout_s: value {self.heartbeat_timeout_s!r} is not "
                             "allowed; expected > 0")


@dataclass(frozen=True)
class BridgeEvent:
    """Something worth a log line: link found/lost, a command's ACK, the track starting."""

    time: float
    uav: int  # -1 for the swarm as a whole
    level: str  # "info" | "warn" | "error"
    text: str


@dataclass(frozen=True)
class VehicleStatus:
    """A snapshot of one UAV as the bridge sees it (positions in metres)."""

    uav: int
    sysid: int
    compid: int
    connection: str
    link: str  # "waiting" (never heard) | "linked" | "lost"
    heartbeat_age_s: float | None
    mode: str
    armed: bool
    position_track: Vec3 | None
    position_ned: Vec3 | None
    position_age_s: float | None
    target_track: Vec3 | None
    setpoints_sent: int
    sequence: str  # "off" | step being run | "done" | "failed: ..."
    last_ack: str


@dataclass
class _Step:
    name: str
    command: int = 0  # 0: a wait step, no command
    params: tuple[float, ...] = ()


@dataclass
class _Vehicle:
    uav: int
    sysid: int
    link: Link
    compid: int = 1
    last_heartbeat: float | None = None
    linked: bool = False
    mode: str = "?"
    armed: bool = False
    custom_mode: int = -1
    position_ned: Vec3 | None = None
    position_time: float | None = None
    setpoints_sent: int = 0
    stream_since: float | None = None
    last_ack: str = ""
    steps: list[_Step] = field(default_factory=list)
    step_index: int = 0
    step_sent_at: float | None = None
    attempts: int = 0
    temp_rejects: int = 0
    climb_target_d: float | None = None
    climb_height: float = 0.0
    climb_deadline: float | None = None
    failed: str = ""

    @property
    def sequence_active(self) -> bool:
        return bool(self.steps) and not self.failed and self.step_index < len(self.steps)

    def sequence_text(self) -> str:
        if not self.steps:
            return "off"
        if self.failed:
            return "failed: " + self.failed
        if self.step_index >= len(self.steps):
            return "done"
        return self.steps[self.step_index].name


class Bridge:
    """Streams formation setpoints to N MAVLink vehicles and watches them (see module doc).

    Links are opened in the constructor (ValueError if the config or a link is bad); the I/O
    thread runs between `start()` and `stop()`. `clock` is monotonic seconds (tests may pass
    their own).
    """

    def __init__(self, config: BridgeConfig, clock: Callable[[], float] = time.monotonic):
        config.validate()
        self.config = config
        self.frame = TrackFrame.from_degrees(config.track_bearing_deg, config.origin_ned_m)
        self._clock = clock
        self._t0 = clock()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._events: deque[BridgeEvent] = deque(maxlen=1000)
        self._formation: list[Vec3 | None] | None = None
        self._t_start: float | None = None
        self._mask = MASK_POSITION_VELOCITY if config.velocity_feedforward else MASK_POSITION
        self._links: dict[str, Link] = {}
        addresses = (config.connections * len(config.target_sysids)
                     if len(config.connections) == 1 else config.connections)
        try:
            for address in dict.fromkeys(addresses):
                self._links[address] = Link(address, config.source_sysid, BRIDGE_COMPID)
        except ValueError as exc:
            self.close()
            raise ValueError(f"connections: {exc}") from None
        self._vehicles = [_Vehicle(k, sysid, self._links[address])
                          for k, (sysid, address) in enumerate(zip(config.target_sysids, addresses,
                                                                   strict=True))]
        self._by_link: dict[int, dict[int, _Vehicle]] = {}
        for v in self._vehicles:
            self._by_link.setdefault(id(v.link), {})[v.sysid] = v

    # ----------------------------------------------------------------- public, thread-safe
    def start(self) -> None:
        """Start the I/O thread (idempotent)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="mavlink-bridge",
                                            daemon=True)
            self._thread.start()

    def stop(self) -> None:
        """Stop the I/O thread and close every link."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        self.close()

    def close(self) -> None:
        for link in self._links.values():
            link.close()

    def __enter__(self) -> Bridge:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def set_formation(self, poses: Sequence[Vec3 | None]) -> None:
        """New formation: poses[k] = (x_k, y_start, z_k) in the track frame, None (or a
        non-finite pose) for a UAV that is not flown. A formation with a different y_start
        restarts the approach; one with the same y_start keeps the track clock running."""
        clean: list[Vec3 | None] = []
        for k in range(len(self._vehicles)):
            p = poses[k] if k < len(poses) else None
            ok = p is not None and all(math.isfinite(float(c)) for c in p)
            clean.append(tuple(float(c) for c in p) if ok else None)
        with self._lock:
            old = self._formation
            same_start = old is not None and all(
                a is None or b is None or abs(a[1] - b[1]) < 1e-3
                for a, b in zip(old, clean, strict=True))
            self._formation = clean
            if not same_start and self._t_start is not None:
                self._t_start = None
                self._event(-1, "info", "new track start: approaching the formation again")
            if self.config.arm_and_takeoff:
                for v in self._vehicles:
                    if clean[v.uav] is not None and not v.steps:
                        v.steps = self._sequence_steps()

    def status(self) -> list[VehicleStatus]:
        """One snapshot per UAV, in UAV order."""
        now = self._clock()
        with self._lock:
            return [self._status(v, now) for v in self._vehicles]

    def link_stats(self) -> dict[str, LinkStats]:
        """Counters per connection string (copies)."""
        with self._lock:
            return {address: replace(link.stats) for address, link in self._links.items()}

    def drain_events(self) -> list[BridgeEvent]:
        """Events since the last call, oldest first."""
        with self._lock:
            out = list(self._events)
            self._events.clear()
            return out

    def track_started(self) -> bool:
        with self._lock:
            return self._t_start is not None

    def target(self, uav: int, now: float) -> tuple[Vec3, Vec3] | None:
        """(position, velocity) of UAV `uav` in the track frame at `now`, or None."""
        with self._lock:
            return self._target(uav, now)

    # ------------------------------------------------------------------ the I/O thread
    def _run(self) -> None:
        period = 1.0 / self.config.setpoint_rate_hz
        now = self._clock()
        next_setpoint, next_heartbeat = now, now
        fds = [fd for fd in (link.fileno() for link in self._links.values()) if fd is not None]
        must_poll = len(fds) < len(self._links)
        while not self._stop.is_set():
            wait = max(0.0, min(next_setpoint, next_heartbeat) - self._clock())
            if must_poll:
                wait = min(wait, 0.01)
            try:
                select.select(fds, [], [], wait)
            except (OSError, ValueError):
                time.sleep(min(wait, 0.01))
            with self._lock:
                now = self._clock()
                for link in self._links.values():
                    for msg in link.poll():
                        self._handle(link, msg, now)
                self._check_links(now)
                self._step_sequences(now)
                if now >= next_heartbeat:
                    self._send_heartbeats()
                    next_heartbeat = max(next_heartbeat + 1.0, now)
                if now >= next_setpoint:
                    self._maybe_start_track(now)
                    self._send_setpoints(now)
                    next_setpoint += period
                    if next_setpoint < now:  # we fell behind (suspended?): do not burst
                        next_setpoint = now + period

    def _event(self, uav: int, level: str, text: str) -> None:
        self._events.append(BridgeEvent(self._clock(), uav, level, text))

    def _handle(self, link: Link, msg: MAV.MAVLink_message, now: float) -> None:
        src = msg.get_srcSystem()
        if src == self.config.source_sysid:
            return  # our own traffic echoed by a router
        v = self._by_link[id(link)].get(src)
        if v is None:
            link.stats.foreign += 1
            return
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            if msg.type in _NOT_VEHICLE_TYPES or msg.autopilot == MAV.MAV_AUTOPILOT_INVALID:
                return  # a camera, GCS or companion on the vehicle's sysid
            seen_before = v.last_heartbeat is not None
            v.compid = msg.get_srcComponent()
            v.last_heartbeat = now
            v.mode = mavutil.mode_string_v10(msg)
            v.custom_mode = msg.custom_mode
            v.armed = bool(msg.base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED)
            if not v.linked:
                v.linked = True
                again = " again" if seen_before else ""
                self._event(v.uav, "info", f"sysid {v.sysid} found{again} ({v.mode}, "
                                           f"{'armed' if v.armed else 'disarmed'})")
                self._send_command(v, MAV.MAV_CMD_SET_MESSAGE_INTERVAL,
                                   (MAV.MAVLINK_MSG_ID_LOCAL_POSITION_NED, POSITION_INTERVAL_US))
                if v.sequence_active:
                    v.step_sent_at, v.attempts, v.temp_rejects = None, 0, 0
        elif kind == "LOCAL_POSITION_NED":
            v.position_ned = (msg.x, msg.y, msg.z)
            v.position_time = now
        elif kind == "COMMAND_ACK":
            if msg.target_system in (0, self.config.source_sysid):
                self._on_ack(v, msg.command, msg.result, now)

    def _check_links(self, now: float) -> None:
        for v in self._vehicles:
            if v.linked and now - v.last_heartbeat > self.config.heartbeat_timeout_s:
                v.linked = False
                self._event(v.uav, "warn", f"sysid {v.sysid} lost: no heartbeat for "
                                           f"{now - v.last_heartbeat:.1f} s")

    def _send_heartbeats(self) -> None:
        for link in self._links.values():
            link.send(link.mav.heartbeat_encode(MAV.MAV_TYPE_ONBOARD_CONTROLLER,
                                                MAV.MAV_AUTOPILOT_INVALID, 0, 0,
                                                MAV.MAV_STATE_ACTIVE))

    def _boot_ms(self, now: float) -> int:
        return int((now - self._t0) * 1000.0) & 0xFFFFFFFF

    def _target(self, uav: int, now: float) -> tuple[Vec3, Vec3] | None:
        if self._formation is None or self._formation[uav] is None:
            return None
        x, y, z = self._formation[uav]
        if self._t_start is None:
            return (x, y, z), (0.0, 0.0, 0.0)
        offset, speed = along_track(now - self._t_start, self.config.speed_mps,
                                    self.config.track_duration_s)
        return (x, y + offset, z), (0.0, speed, 0.0)

    def _maybe_start_track(self, now: float) -> None:
        if self._t_start is not None or self._formation is None:
            return
        gate = [v for v in self._vehicles
                if self._formation[v.uav] is not None and v.linked and not v.failed]
        if self.config.capture_radius_m > 0.0:
            if not gate:
                return
            for v in gate:
                fresh = (v.position_time is not None
                         and now - v.position_time < self.config.heartbeat_timeout_s)
                if not fresh:
                    return
                start = self.frame.to_ned(*self._formation[v.uav])
                if math.dist(start, v.position_ned) > self.config.capture_radius_m:
                    return
        self._t_start = now
        self._event(-1, "info", f"formation established; flying the track at "
                                f"{self.config.speed_mps:g} m/s")

    def _send_setpoints(self, now: float) -> None:
        for v in self._vehicles:
            target = self._target(v.uav, now)
            holding_for_takeoff = (self.config.autopilot == "ardupilot" and v.sequence_active)
            if target is None or holding_for_takeoff:
                v.stream_since = None
                continue
            (n, e, d) = self.frame.to_ned(*target[0])
            vn, ve, vd = (self.frame.vector_to_ned(*target[1])
                          if self.config.velocity_feedforward else (0.0, 0.0, 0.0))
            v.link.send(v.link.mav.set_position_target_local_ned_encode(
                self._boot_ms(now), v.sysid, v.compid, MAV.MAV_FRAME_LOCAL_NED, self._mask,
                n, e, d, vn, ve, vd, 0.0, 0.0, 0.0, 0.0, 0.0))
            v.setpoints_sent += 1
            if v.stream_since is None:
                v.stream_since = now

    # ------------------------------------------------------- arm and take off (optional)
    def _sequence_steps(self) -> list[_Step]:
        arm = _Step("arm", MAV.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
        custom = float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
        if self.config.autopilot == "px4":
            return [_Step("stream setpoints"),
                    _Step("mode OFFBOARD", MAV.MAV_CMD_DO_SET_MODE,
                          (custom, float(PX4_MAIN_MODE_OFFBOARD), 0.0)),
                    arm]
        return [_Step("mode GUIDED", MAV.MAV_CMD_DO_SET_MODE,
                      (custom, float(COPTER_MODE_GUIDED))),
                arm,
                _Step("takeoff", MAV.MAV_CMD_NAV_TAKEOFF),
                _Step("climb")]

    def _send_command(self, v: _Vehicle, command: int, params: Sequence[float],
                      confirmation: int = 0) -> None:
        p = [float(x) for x in params] + [0.0] * (7 - len(params))
        v.link.send(v.link.mav.command_long_encode(v.sysid, v.compid, command, confirmation,
                                                   *p))

    def _already_in_control(self, v: _Vehicle) -> bool:
        wanted = (PX4_MAIN_MODE_OFFBOARD << 16 if self.config.autopilot == "px4"
                  else COPTER_MODE_GUIDED)
        if self.config.autopilot == "px4":
            return v.armed and (v.custom_mode & 0x00FF0000) == wanted
        return v.armed and v.custom_mode == wanted and self._airborne(v)

    def _airborne(self, v: _Vehicle) -> bool:
        return v.position_ned is not None and v.position_ned[2] < -0.5

    def _step_sequences(self, now: float) -> None:
        for v in self._vehicles:
            if not v.sequence_active or not v.linked:
                continue
            step = v.steps[v.step_index]
            if v.step_index == 0 and v.step_sent_at is None and self._already_in_control(v):
                v.step_index = len(v.steps)
                self._event(v.uav, "info", f"sysid {v.sysid} already armed in {v.mode}; "
                                           "arming sequence skipped")
                continue
            if step.name == "stream setpoints":
                if v.stream_since is not None and \
                        now - v.stream_since > PX4_STREAM_BEFORE_OFFBOARD_S:
                    self._advance(v, now)
                continue
            if step.name == "climb":
                self._step_climb(v, now)
                continue
            if step.command == MAV.MAV_CMD_NAV_TAKEOFF and v.step_sent_at is None \
                    and self._airborne(v):
                self._event(v.uav, "info", f"sysid {v.sysid} already airborne; no takeoff")
                self._advance(v, now)
                self._advance(v, now)  # and no climb to wait for
                continue
            if v.step_sent_at is None or now - v.step_sent_at > COMMAND_TIMEOUT_S:
                if v.attempts >= COMMAND_ATTEMPTS:
                    self._fail(v, f"{step.name}: no COMMAND_ACK after {v.attempts} tries")
                    continue
                if step.command == MAV.MAV_CMD_NAV_TAKEOFF:
                    step.params = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, self._takeoff_altitude(v))
                self._send_command(v, step.command, step.params, confirmation=v.attempts)
                v.step_sent_at = now
                v.attempts += 1

    def _takeoff_altitude(self, v: _Vehicle) -> float:
        """Metres above the current (home) height up to the formation's start height."""
        start_d = self.frame.to_ned(*self._formation[v.uav])[2]
        home_d = v.position_ned[2] if v.position_ned is not None else 0.0
        v.climb_target_d = start_d
        # ArduPilot refuses takeoff to <= 0 m; a formation below the ground is the plan's
        # problem, so climb to 1 m and let the setpoints bring the vehicle down.
        v.climb_height = max(home_d - start_d, 1.0)
        return v.climb_height

    def _step_climb(self, v: _Vehicle, now: float) -> None:
        if v.climb_deadline is None:  # a copter climbs at >= 1 m/s (ArduCopter WPNAV_SPEED_UP)
            v.climb_deadline = now + v.climb_height / 1.0 + CLIMB_TIMEOUT_EXTRA_S
        reached = (v.position_ned is not None and v.climb_target_d is not None
                   and v.position_ned[2] <= v.climb_target_d + 1.0)
        if reached:
            self._advance(v, now)
        elif now > v.climb_deadline:
            self._event(v.uav, "warn", f"sysid {v.sysid}: takeoff altitude not confirmed by "
                                       "LOCAL_POSITION_NED; streaming setpoints anyway")
            self._advance(v, now)

    def _advance(self, v: _Vehicle, now: float) -> None:
        v.step_index += 1
        v.step_sent_at, v.attempts, v.temp_rejects = None, 0, 0
        if v.step_index >= len(v.steps):
            self._event(v.uav, "info", f"sysid {v.sysid}: armed and under our control")

    def _fail(self, v: _Vehicle, why: str) -> None:
        v.failed = why
        self._event(v.uav, "error", f"sysid {v.sysid}: {why}")

    def _on_ack(self, v: _Vehicle, command: int, result: int, now: float) -> None:
        v.last_ack = f"{command_name(command)}: {result_name(result)}"
        if not v.sequence_active:
            if command != MAV.MAV_CMD_SET_MESSAGE_INTERVAL or result != MAV.MAV_RESULT_ACCEPTED:
                self._event(v.uav, "info", f"sysid {v.sysid} COMMAND_ACK {v.last_ack}")
            return
        step = v.steps[v.step_index]
        if command != step.command or v.step_sent_at is None:
            return
        if result == MAV.MAV_RESULT_ACCEPTED:
            self._event(v.uav, "info", f"sysid {v.sysid} {step.name}: ACCEPTED")
            self._advance(v, now)
        elif result == MAV.MAV_RESULT_IN_PROGRESS:
            v.step_sent_at = now  # keep waiting for the final ACK
        elif result == MAV.MAV_RESULT_TEMPORARILY_REJECTED and \
                v.temp_rejects < TEMP_REJECT_ATTEMPTS:
            v.temp_rejects += 1
            v.attempts = 0  # a rejection is an answer, not a lost packet: retry after 1 s
            self._event(v.uav, "warn", f"sysid {v.sysid} {step.name}: TEMPORARILY_REJECTED, "
                                       "retrying")
        else:
            self._fail(v, f"{step.name}: {result_name(result)}")

    def _status(self, v: _Vehicle, now: float) -> VehicleStatus:
        link = "linked" if v.linked else ("lost" if v.last_heartbeat is not None else "waiting")
        target = self._target(v.uav, now)
        return VehicleStatus(
            uav=v.uav, sysid=v.sysid, compid=v.compid, connection=v.link.address, link=link,
            heartbeat_age_s=None if v.last_heartbeat is None else now - v.last_heartbeat,
            mode=v.mode, armed=v.armed,
            position_track=None if v.position_ned is None else self.frame.from_ned(
                *v.position_ned),
            position_ned=v.position_ned,
            position_age_s=None if v.position_time is None else now - v.position_time,
            target_track=None if target is None else target[0],
            setpoints_sent=v.setpoints_sent, sequence=v.sequence_text(), last_ack=v.last_ack)
