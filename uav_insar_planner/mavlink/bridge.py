"""The swarm bridge: formation in the track frame -> SET_POSITION_TARGET_LOCAL_NED per UAV.

This module is the I/O loop; the formation and hold state it serves is `flight_state`'s.
Contract (each point's detail is in the module named):
- One MAVLink link per distinct connection string; several UAVs may share one (a router),
  each addressed by its sysid and the component its heartbeat came from (`link`).
- Setpoints in MAV_FRAME_LOCAL_NED at `setpoint_rate_hz` (`setpoints`) along the pass
  (`track.trajectory`), started by the capture gate or the planner's instant (`start_gate`).
  Where the autopilot ignores setpoints outside its flight mode (ArduPilot: GUIDED) none go
  to a vehicle not in it (nor during its takeoff); else (PX4) the stream never stops: OFFBOARD
  needs it before and on return (`autopilots.profiles`). `uav_id` >= 0: one vehicle, UAV `uav_id`.
- Our HEARTBEAT at 1 Hz as (source_sysid, 191); vehicles found, lost and their `phase`
  (`supervision`); LOCAL_POSITION_NED requested at 10 Hz and read back.
- Optional arm_and_takeoff (`sequencer`), each COMMAND_ACK and PreArm reason an event.
- Holds (`holds`): the planner's mission stop (every pose NaN) and the ground station's
  silence for `gcs_timeout_s`; a held vehicle at most `holds.REJOIN_S` of the pass behind
  its target rejoins when the ground is heard again or a new start or plan comes, one
  farther behind keeps holding and is reported `behind` (the planner resumes the swarm from
  where it holds or replans without it; under pass_start "capture" a new plan resumes the
  pass where the swarm holds).
- Two planned UAVs closer than `min_separation_m` are warned about (`separation`).
- Bad values are dropped where they cross, counted and logged rate-limited (`guard`):
  `unsendable`, `bad_value`, `spoofed` (supervision.unexpected_source); optional MAVLink 2
  signing (`signing`, `bad_signature`).

All I/O runs in one background thread (`start()` / `stop()`, `io_thread`); `set_formation`,
`set_start`, `gcs_heard`, `gcs_state`, `status`, `link_stats`, `drain_events`,
`track_started` and `target` are thread-safe and are what the ROS node calls.
"""
from __future__ import annotations

import select
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import replace

from uav_insar_planner.mavlink.config import BridgeConfig
from uav_insar_planner.mavlink.flight_state import FlightState
from uav_insar_planner.mavlink.guard import DropLog
from uav_insar_planner.mavlink.io_thread import IoThread
from uav_insar_planner.mavlink.link import MAV, Link, LinkStats, Source, open_links
from uav_insar_planner.mavlink.report import BridgeEvent, VehicleStatus
from uav_insar_planner.mavlink.sequencer import command_name, result_name
from uav_insar_planner.mavlink.setpoints import (
    boot_ms,
    command_message,
    companion_heartbeat,
    setpoint_message,
)
from uav_insar_planner.mavlink.supervision import WatchedVehicle, is_vehicle_heartbeat
from uav_insar_planner.plan import Vec3
from uav_insar_planner.swarm import MAX_UAVS
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.leg import SurveyLeg

__all__ = ["Bridge", "BridgeConfig", "BridgeEvent", "VehicleStatus"]

BRIDGE_COMPID = MAV.MAV_COMP_ID_ONBOARD_COMPUTER  # 191
POSITION_INTERVAL_US = 100_000  # ask for LOCAL_POSITION_NED at 10 Hz


class Bridge(IoThread):
    """Streams formation setpoints to N MAVLink vehicles and watches them (see module doc).

    Links are opened in the constructor (ValueError if the config or a link is bad); the I/O
    thread runs between `start()` and `stop()`. `clock` is monotonic seconds (tests may pass
    their own).
    """

    def __init__(self, config: BridgeConfig, clock: Callable[[], float] = time.monotonic):
        config.validate()
        super().__init__("mavlink-bridge")
        self.config = config
        self._clock = clock
        self._t0 = clock()
        self._lock = threading.Lock()
        #: why the I/O thread died (None while it runs or never ran): nothing is sent then,
        #: and whoever reports the bridge's health must say so.
        self.failure: str | None = None
        self._events: deque[BridgeEvent] = deque(maxlen=1000)
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
        count = max(self.uavs) + 1 if config.uav_id < 0 else MAX_UAVS
        self._flight = FlightState(
            config, TrackFrame.from_degrees(config.track_bearing_deg, config.origin_ned_m),
            self._vehicles, count, self._event, self._send_command)
        self._by_link: dict[int, dict[int, WatchedVehicle]] = {}
        for v in self._vehicles:
            self._by_link.setdefault(id(v.link), {})[v.sysid] = v

    # ----------------------------------------------------------------- public, thread-safe
    def close(self) -> None:
        for link in self._links.values():
            link.close()

    def set_formation(self, poses: Sequence[Vec3 | None], leg: SurveyLeg | None = None) -> None:
        """New formation: poses[k] = (x_k, y_start, z_k) in the track frame, None or NaN: not
        flown, on the survey strip `leg` (None: a single pass). Another y_start or strip
        restarts the approach; the same keeps the track clock."""
        with self._lock:
            self._flight.set_formation(poses, self._clock(), leg)

    @property
    def frame(self) -> TrackFrame:
        """The track frame flown: the configured one, or the survey strip's on it."""
        with self._lock:
            return self._flight.frame

    def gcs_heard(self, what: str, heartbeat: bool = False, newer_plan: bool = False) -> None:
        """Something came from the ground station (`what`: a heartbeat, plan or start;
        `heartbeat`: a gcs/heartbeat, which starts the silence clock; `newer_plan`: it is of,
        or names, a plan other than the one flown, so held vehicles wait for that plan)."""
        with self._lock:
            self._flight.gcs_heard(what, self._clock(), heartbeat, newer_plan)

    def gcs_state(self) -> str:
        """The ground station's link as the bridge sees it (holds.GcsWatch.state)."""
        with self._lock:
            return self._flight.holding.gcs.state(self._clock())

    def status(self) -> list[VehicleStatus]:
        """One snapshot per UAV, in UAV order."""
        now = self._clock()
        with self._lock:
            return [self._flight.status(v, now) for v in self._vehicles]

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
            return self._flight.pass_.running(self._clock())

    def set_start(self, wall_time_s: float, label: str, offset_m: float = 0.0) -> None:
        """pass_start "planner": plan `label`'s pass starts at `wall_time_s` (time.time()),
        `offset_m` past its start line (start_gate.planner_start)."""
        if self.config.pass_start != "planner":
            return
        with self._lock:
            self._flight.set_start(wall_time_s, self._clock(), label, offset_m)

    def target(self, uav: int, now: float) -> tuple[Vec3, Vec3] | None:
        """(position, velocity) of UAV `uav` in the track frame at `now`, or None."""
        with self._lock:
            return self._flight.pass_.target(uav, now)

    # ------------------------------------------------------------------ the I/O thread
    def run(self) -> None:
        try:
            self._loop()
        except Exception as exc:  # recorded, never silent: the node turns every UAV ERROR
            self.failure = f"{type(exc).__name__}: {exc}"
            self._event(-1, "error", "MAVLink I/O thread died: " + self.failure)

    def _loop(self) -> None:
        period = 1.0 / self.config.setpoint_rate_hz
        now = self._clock()
        next_setpoint, next_heartbeat = now, now
        while not self.stopping:
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
                self._flight.check(now)
                if now >= next_heartbeat:
                    for link in self._links.values():
                        link.send(companion_heartbeat(link.mav))
                    next_heartbeat = max(next_heartbeat + 1.0, now)
                if now >= next_setpoint:
                    self._flight.capture(now)
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
                if seq := self._flight.running(v):
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
        if seq := self._flight.running(v):
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
            if order := self._flight.order_due(v, now):
                self._send_command(v, order.command, order.params)
                order.sent(v, now)
            target = self._flight.target_to_send(v, now)
            if target is None:
                v.stream_since = None
                continue
            msg = setpoint_message(v.link.mav, self._flight.frame, target, boot_ms(now - self._t0),
                                   v.sysid, v.compid, self.config.velocity_feedforward)
            if msg is None:
                self._drop(v, "unsendable", f"setpoint for target {target}: not float32")
                continue
            v.link.send(msg)
            v.setpoints_sent += 1
            if v.stream_since is None:
                v.stream_since = now
