"""The swarm bridge: formation in the track frame -> SET_POSITION_TARGET_LOCAL_NED per UAV.

Contract (each point's detail is in the module named):
- One MAVLink link per distinct connection string; several UAVs may share one (a router),
  each addressed by its sysid and the component its heartbeat came from (`link`).
- Setpoints in MAV_FRAME_LOCAL_NED at `setpoint_rate_hz` (`setpoints`) along the pass
  (`trajectory`), started by the capture gate or the planner's instant (`pass_start`).
  ArduPilot: none to a vehicle not in GUIDED (nor during its takeoff); PX4: the stream never
  stops (OFFBOARD needs it before and on return). `uav_id` >= 0: one vehicle, UAV `uav_id`.
- Our HEARTBEAT at 1 Hz as (source_sysid, 191); vehicles found, lost and their `phase`
  (`supervision`); LOCAL_POSITION_NED requested at 10 Hz and read back.
- Optional arm_and_takeoff (`sequencer`), each COMMAND_ACK and PreArm reason an event.
- Holds (`holding`): the planner's mission stop (every pose NaN) and the ground station's
  silence for `gcs_timeout_s`; a held vehicle at most `holding.REJOIN_S` of the pass behind
  its target rejoins when the ground is heard again or a new start or plan comes, one
  farther behind keeps holding and is reported `behind` (the planner resumes the swarm from
  where it holds or replans without it; under pass_start "capture" a new plan resumes the
  pass where the swarm holds).
- Two planned UAVs closer than `min_separation_m` are warned about (`separation`).
- Bad values are dropped where they cross, counted and logged rate-limited (`guard`):
  `unsendable`, `bad_value`, `spoofed` (supervision.unexpected_source); optional MAVLink 2
  signing (`signing`, `bad_signature`).

All I/O runs in one background thread (`start()` / `stop()`); `set_formation`, `set_start`,
`gcs_heard`, `gcs_state`, `status`, `link_stats`, `drain_events`, `track_started` and `target`
are thread-safe and are what the ROS node calls.
"""
from __future__ import annotations

import select
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import replace

from uav_insar_planner.mavlink.catch_up import CATCH_UP_FROM_M, CatchUp, governed
from uav_insar_planner.mavlink.config import BridgeConfig
from uav_insar_planner.mavlink.frames import TrackFrame, Vec3
from uav_insar_planner.mavlink.guard import DropLog
from uav_insar_planner.mavlink.holding import REJOIN_S, Holding
from uav_insar_planner.mavlink.link import MAV, Link, LinkStats, Source, open_links
from uav_insar_planner.mavlink.pass_start import (
    capture_start,
    lags,
    planner_start,
    resume_where_held,
)
from uav_insar_planner.mavlink.report import BridgeEvent, VehicleStatus, vehicle_status
from uav_insar_planner.mavlink.sequencer import (
    COPTER_MODE_GUIDED,
    ArmingSequence,
    command_name,
    result_name,
)
from uav_insar_planner.mavlink.setpoints import (
    boot_ms,
    command_message,
    companion_heartbeat,
    setpoint_message,
)
from uav_insar_planner.mavlink.supervision import WatchedVehicle, is_vehicle_heartbeat
from uav_insar_planner.mavlink.trajectory import PassTrajectory, clean_formation, separation
from uav_insar_planner.swarm import MAX_UAVS

__all__ = ["Bridge", "BridgeConfig", "BridgeEvent", "VehicleStatus"]

BRIDGE_COMPID = MAV.MAV_COMP_ID_ONBOARD_COMPUTER  # 191
POSITION_INTERVAL_US = 100_000  # ask for LOCAL_POSITION_NED at 10 Hz


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
        #: why the I/O thread died (None while it runs or never ran): nothing is sent then,
        #: and whoever reports the bridge's health must say so.
        self.failure: str | None = None
        self._events: deque[BridgeEvent] = deque(maxlen=1000)
        self._pass = PassTrajectory(config.speed_mps, config.track_duration_s)
        self._start_label = ""  # the plan whose pass start the track clock is (planner)
        self._catch_up: dict[int, CatchUp] = {}  # vehicles catching up after a rejoin
        self._drops = DropLog(clock=clock)
        addresses = config.addresses()
        self._links, warning = open_links(addresses, config.source_sysid,
                                          BRIDGE_COMPID, config.signing_key_file)
        if warning:
            self._event(-1, "warn", warning)
        self.uavs = config.uavs()  # the UAV index of each vehicle
        self._vehicles = [WatchedVehicle(k, sysid, self._links[address],
                                         expected_source=self._links[address].peer_address)
                          for k, sysid, address
                          in zip(self.uavs, config.target_sysids, addresses, strict=True)]
        # poses read: one per vehicle, or every pose a plan may have (separation from the others)
        self._count = max(self.uavs) + 1 if config.uav_id < 0 else MAX_UAVS
        self._separation = [""] * self._count
        self._sequences: dict[int, ArmingSequence] = {}  # per UAV, once arm_and_takeoff ran
        self._holding = Holding(config.autopilot, config.gcs_timeout_s,
                                [v.uav for v in self._vehicles], self._event)
        self._by_link: dict[int, dict[int, WatchedVehicle]] = {}
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
        """New formation: poses[k] = (x_k, y_start, z_k) in the track frame, None or NaN: not
        flown. Another y_start restarts the approach; the same keeps the track clock."""
        clean = clean_formation(poses, self._count)
        with self._lock:
            now = self._clock()
            flown = self._pass.formation is not None and any(self._pass.formation)
            self._holding.on_plan(clean, flown)
            if self._pass.set_formation(clean):
                self._event(-1, "info", "new track start: approaching the formation again")
            self._rejoin(now, "a new plan", here=self.config.pass_start != "planner")
            self._separation, warnings = separation(clean, self.config.min_separation_m)
            for text in warnings:
                self._event(-1, "warn", text)
            if self.config.arm_and_takeoff:
                for v in self._vehicles:
                    if clean[v.uav] is not None and v.uav not in self._sequences:
                        self._sequences[v.uav] = self._new_sequence(v)

    def gcs_heard(self, what: str, heartbeat: bool = False) -> None:
        """Something came from the ground station (`what`: a heartbeat, plan or start;
        `heartbeat`: a gcs/heartbeat, which starts the silence clock)."""
        with self._lock:
            now = self._clock()
            if self._holding.gcs_heard(what, now, heartbeat):
                self._rejoin(now, "the ground station heard again")

    def gcs_state(self) -> str:
        """The ground station's link as the bridge sees it (holding.GcsWatch.state)."""
        with self._lock:
            return self._holding.gcs.state(self._clock())

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
            return self._pass.t_start is not None and self._clock() >= self._pass.t_start

    def set_start(self, wall_time_s: float, label: str, offset_m: float = 0.0) -> None:
        """pass_start "planner": plan `label`'s pass starts at `wall_time_s` (time.time()),
        `offset_m` past its start line (pass_start.planner_start)."""
        if self.config.pass_start != "planner":
            return
        with self._lock:
            now = self._clock()
            text = planner_start(self._pass, wall_time_s, now, time.time(), label, offset_m)
            self._start_label = label if self._pass.formation is not None else ""
            if text:  # held ones near their targets rejoin, ones too late to keep up hold
                self._event(-1, "info", text)
                self._rejoin(now, "a new pass start", late=True)

    def target(self, uav: int, now: float) -> tuple[Vec3, Vec3] | None:
        """(position, velocity) of UAV `uav` in the track frame at `now`, or None."""
        with self._lock:
            return self._pass.target(uav, now)

    def _rejoin(self, now: float, why: str, here: bool = False, late: bool = False) -> None:
        """Held vehicles near their targets rejoin (`holding.rejoin`); `here`: the clock first
        moves to where the rearmost held one stands; `late`: `holding.fall_back`."""
        lag = lags(self._vehicles, self._pass, self.frame, now)
        held = [lag[v.uav] for v in self._vehicles if self._holding.stopped(v)]
        if here and (text := resume_where_held(self._pass, held)):
            self._event(-1, "info", text)
            lag = lags(self._vehicles, self._pass, self.frame, now)
        rejoin_m = self.config.speed_mps * REJOIN_S
        given = self._holding.rejoin(self._vehicles, lag, rejoin_m, why)
        if late:
            self._holding.fall_back(self._vehicles, lag, rejoin_m, why)
        for v in self._vehicles:  # behind a moving target: a gentle catch-up (`catch_up`)
            if (v.uav in given or late and not self._holding.stopped(v)) and (
                    lag[v.uav] or 0.0) > CATCH_UP_FROM_M:
                y = self.frame.from_ned(*v.position_ned)[1]
                self._catch_up[v.uav] = CatchUp(now, y, self.config.speed_mps)

    # ------------------------------------------------------------------ the I/O thread
    def _run(self) -> None:
        try:
            self._loop()
        except Exception as exc:  # recorded, never silent: the node turns every UAV ERROR
            self.failure = f"{type(exc).__name__}: {exc}"
            self._event(-1, "error", "MAVLink I/O thread died: " + self.failure)

    def _loop(self) -> None:
        period = 1.0 / self.config.setpoint_rate_hz
        now = self._clock()
        next_setpoint, next_heartbeat = now, now
        while not self._stop.is_set():
            # TCP descriptors change on reconnect, and a link without one must be polled
            fds = [fd for fd in (link.fileno() for link in self._links.values())
                   if fd is not None]
            must_poll = len(fds) < len(self._links)
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
                    for msg, source in link.poll_sources():
                        self._handle(link, msg, source, now)
                self._check_links(now)
                self._holding.check(now)
                for v in self._vehicles:
                    if (seq := self._running(v)) and v.linked:
                        seq.step(now)
                if now >= next_heartbeat:
                    for link in self._links.values():
                        link.send(companion_heartbeat(link.mav))
                    next_heartbeat = max(next_heartbeat + 1.0, now)
                if now >= next_setpoint:
                    if capture_start(self._vehicles, self._sequences, self._pass, self.frame,
                                     now, self.config):
                        self._event(-1, "info", f"formation established; flying the track "
                                                f"at {self.config.speed_mps:g} m/s")
                    self._send_setpoints(now)
                    next_setpoint += period
                    if next_setpoint < now:  # we fell behind (suspended?): do not burst
                        next_setpoint = now + period

    def _event(self, uav: int, level: str, text: str) -> None:
        self._events.append(BridgeEvent(self._clock(), uav, level, text))

    def _drop(self, v: WatchedVehicle, counter: str, detail: str) -> None:
        """Count a dropped message in its link's `counter`; log it at a bounded rate."""
        setattr(v.link.stats, counter, getattr(v.link.stats, counter) + 1)
        line = self._drops.drop(f"{counter} (sysid {v.sysid})", detail)
        if line is not None:
            self._event(v.uav, "warn", line)

    def _running(self, v: WatchedVehicle) -> ArmingSequence | None:
        seq = self._sequences.get(v.uav)
        return seq if seq is not None and seq.active else None

    def _new_sequence(self, v: WatchedVehicle) -> ArmingSequence:
        def start_down() -> float:
            return self.frame.to_ned(*self._pass.start_pose(v.uav))[2]

        return ArmingSequence(
            self.config.autopilot, v,
            send=lambda command, params, confirmation: self._send_command(
                v, command, params, confirmation),
            emit=lambda level, text: self._event(v.uav, level, text), start_down=start_down,
            readiness_timeout_s=self.config.readiness_timeout_s)

    def _handle(self, link: Link, msg: MAV.MAVLink_message, source: Source | None,
                now: float) -> None:
        src = msg.get_srcSystem()
        if src == self.config.source_sysid:
            return  # our own traffic echoed by a router
        v = self._by_link[id(link)].get(src)
        if v is None:
            link.stats.foreign += 1
            return
        kind = msg.get_type()
        if kind == "HEARTBEAT" and not is_vehicle_heartbeat(msg):
            return  # a camera, GCS or companion on the vehicle's sysid
        why = v.unexpected_source(msg, source)
        if why:
            self._drop(v, "spoofed", f"{kind} {why}")
            return
        if kind == "HEARTBEAT":
            found = v.on_heartbeat(msg, now, source)
            if found is not None:
                self._event(v.uav, "info", found)
                self._send_command(v, MAV.MAV_CMD_SET_MESSAGE_INTERVAL,
                                   (MAV.MAVLINK_MSG_ID_LOCAL_POSITION_NED, POSITION_INTERVAL_US))
                if seq := self._running(v):
                    seq.retry_now()
        elif kind == "LOCAL_POSITION_NED":
            if not v.on_position(msg, now):
                self._drop(v, "bad_value", f"LOCAL_POSITION_NED ({msg.x}, {msg.y}, {msg.z})")
        elif kind == "STATUSTEXT":
            reason = v.on_statustext(msg)
            if reason is not None:
                self._event(v.uav, "warn", f"sysid {v.sysid} {reason}")
        elif kind == "GPS_RAW_INT":
            v.gps_fix = msg.fix_type
        elif kind == "HOME_POSITION":
            v.home_seen = True
        elif kind == "COMMAND_ACK":
            if msg.target_system in (0, self.config.source_sysid):
                self._on_ack(v, msg.command, msg.result, now)

    def _on_ack(self, v: WatchedVehicle, command: int, result: int, now: float) -> None:
        v.last_ack = f"{command_name(command)}: {result_name(result)}"
        if seq := self._running(v):
            seq.on_ack(command, result, now)
        elif command != MAV.MAV_CMD_SET_MESSAGE_INTERVAL or result != MAV.MAV_RESULT_ACCEPTED:
            self._event(v.uav, "info", f"sysid {v.sysid} COMMAND_ACK {v.last_ack}")

    def _check_links(self, now: float) -> None:
        for v in self._vehicles:
            lost = v.check_timeout(now, self.config.heartbeat_timeout_s)
            if lost is not None:
                self._event(v.uav, "warn", lost)

    def _send_command(self, v: WatchedVehicle, command: int, params: Sequence[float],
                      confirmation: int = 0) -> None:
        msg = command_message(v.link.mav, v.sysid, v.compid, command, params, confirmation)
        if msg is None:
            self._drop(v, "unsendable", f"{command_name(command)} params {list(params)}")
        else:
            v.link.send(msg)

    def _send_setpoints(self, now: float) -> None:
        for v in self._vehicles:
            if order := self._holding.order_due(v, now):
                self._send_command(v, order.command, order.params)
                order.sent(v, now)
            target = governed(self._catch_up, v.uav, self._pass.target(v.uav, now), now)
            ardupilot = self.config.autopilot == "ardupilot"
            holding = ardupilot and (self._running(v) or v.custom_mode != COPTER_MODE_GUIDED)
            if target is None or holding or self._holding.stopped(v):
                v.stream_since = None
                continue
            msg = setpoint_message(v.link.mav, self.frame, target, boot_ms(now - self._t0),
                                   v.sysid, v.compid, self.config.velocity_feedforward)
            if msg is None:
                self._drop(v, "unsendable", f"setpoint for target {target}: not float32")
                continue
            v.link.send(msg)
            v.setpoints_sent += 1
            if v.stream_since is None:
                v.stream_since = now

    def _status(self, v: WatchedVehicle, now: float) -> VehicleStatus:
        status = vehicle_status(v, now, self._pass, self.frame, self.config.capture_radius_m,
                                self._sequences.get(v.uav), self._separation[v.uav])
        held = self._holding.phase(v)
        return replace(status, phase=held or status.phase, pass_plan=self._start_label,
                       behind=self._holding.behind.get(v.uav, ""))
