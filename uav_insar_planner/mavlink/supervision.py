"""Link supervision: what the bridge knows of one vehicle from its heartbeats and positions.

A UAV is found on its first vehicle HEARTBEAT (one from a camera, GCS or companion on the same
sysid does not count), lost after `heartbeat_timeout_s` without one, and found again when one
returns. LOCAL_POSITION_NED is kept with the time it arrived; HOME_POSITION, the GPS fix
(GPS_RAW_INT) and the latest arming refusal reason (STATUSTEXT "PreArm: ..." / "Arm: ...") are
kept for the readiness phase (`position_ready`, `prearm`). A non-finite position is not
kept (`on_position` returns False): it counts as no telemetry.

Source checks (`unexpected_source`), without signing the only ones MAVLink allows: on UDP a
vehicle's messages must come from one address, the one we send to on a `udpout` link, else
the first one heard (again after each loss) on `udpin`; while linked, its HEARTBEAT,
LOCAL_POSITION_NED and COMMAND_ACK must come from the component its first heartbeat came from.
TCP and serial links carry no per-message address, and a router merges every sender into
one: there only the component can be checked, and anyone who can write to the link can
claim a sysid; MAVLink 2 signing (`signing`) is the answer there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink import mavutil

from uav_insar_planner.mavlink.link import MAV, Link, Source
from uav_insar_planner.plan import Vec3

_NOT_VEHICLE_TYPES = frozenset((MAV.MAV_TYPE_GCS, MAV.MAV_TYPE_ONBOARD_CONTROLLER,
                                MAV.MAV_TYPE_GIMBAL, MAV.MAV_TYPE_ADSB, MAV.MAV_TYPE_CAMERA,
                                MAV.MAV_TYPE_ANTENNA_TRACKER))
_AUTOPILOT_ONLY = frozenset(("HEARTBEAT", "LOCAL_POSITION_NED", "COMMAND_ACK"))


def is_vehicle_heartbeat(msg: MAV.MAVLink_message) -> bool:
    """True for a HEARTBEAT from the autopilot itself."""
    return msg.type not in _NOT_VEHICLE_TYPES and msg.autopilot != MAV.MAV_AUTOPILOT_INVALID


@dataclass
class WatchedVehicle:
    """One UAV as the bridge sees it (its arming sequence, if any, is the bridge's:
    `sequencer.ArmingSequence` reads this record, never the other way round)."""

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
    home_seen: bool = False
    gps_fix: int | None = None  # GPS_RAW_INT.fix_type, None: never reported
    prearm: str = ""  # the latest arming refusal reason, "" once armed
    expected_source: Source | None = None  # udpout: the address we send to
    source: Source | None = None  # udpin: the address first heard since the last loss

    def unexpected_source(self, msg: MAV.MAVLink_message, source: Source | None) -> str:
        """"" when `msg` (attributed to this sysid) may be the vehicle's, else why not."""
        pinned = self.expected_source or self.source
        if source is not None and pinned is not None and tuple(source) != tuple(pinned):
            return f"from {source[0]}:{source[1]}, not {pinned[0]}:{pinned[1]}"
        if self.linked and msg.get_type() in _AUTOPILOT_ONLY and \
                msg.get_srcComponent() != self.compid:
            return f"from component {msg.get_srcComponent()}, not {self.compid}"
        return ""

    def position_ready(self, now: float, max_age_s: float) -> str:
        """"" when the vehicle reports a usable position (LOCAL_POSITION_NED flowing, i.e. an
        EKF origin, or a HOME_POSITION; and a 3D fix where GPS_RAW_INT is reported), else
        what is missing."""
        if self.gps_fix is not None and self.gps_fix < MAV.GPS_FIX_TYPE_3D_FIX:
            return f"waiting for a GPS 3D fix (fix type {self.gps_fix})"
        if not (self.position_fresh(now, max_age_s) or self.home_seen):
            return "waiting for position (LOCAL_POSITION_NED / HOME_POSITION)"
        return ""

    def on_statustext(self, msg: MAV.MAVLink_message) -> str | None:
        """Take a STATUSTEXT; return the reason when it is a new arming refusal."""
        text = msg.text.rstrip("\x00").strip() if isinstance(msg.text, str) else ""
        if not text.lower().startswith(("prearm", "arm:")):
            return None
        if text == self.prearm:
            return None
        self.prearm = text
        return text

    @property
    def link_state(self) -> str:
        """"waiting" (never heard) | "linked" | "lost"."""
        return "linked" if self.linked else (
            "lost" if self.last_heartbeat is not None else "waiting")

    @property
    def airborne(self) -> bool:
        return self.position_ned is not None and self.position_ned[2] < -0.5

    def on_heartbeat(self, msg: MAV.MAVLink_message, now: float,
                     source: Source | None = None) -> str | None:
        """Take a vehicle heartbeat; return the event text when the link is (re)found."""
        seen_before = self.last_heartbeat is not None
        if self.source is None:
            self.source = source
        self.compid = msg.get_srcComponent()
        self.last_heartbeat = now
        self.mode = mavutil.mode_string_v10(msg)
        self.custom_mode = msg.custom_mode
        self.armed = bool(msg.base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED)
        if self.armed:
            self.prearm = ""
        if self.linked:
            return None
        self.linked = True
        again = " again" if seen_before else ""
        return (f"sysid {self.sysid} found{again} ({self.mode}, "
                f"{'armed' if self.armed else 'disarmed'})")

    def on_position(self, msg: MAV.MAVLink_message, now: float) -> bool:
        """Keep a LOCAL_POSITION_NED; False (not kept) when x, y or z is not finite."""
        position = (msg.x, msg.y, msg.z)
        if not all(math.isfinite(c) for c in position):
            return False
        self.position_ned = position
        self.position_time = now
        return True

    def check_timeout(self, now: float, timeout_s: float) -> str | None:
        """Mark the link lost after `timeout_s` of silence; return the event text if so."""
        if self.linked and now - self.last_heartbeat > timeout_s:
            self.linked, self.source = False, None
            return f"sysid {self.sysid} lost: no heartbeat for {now - self.last_heartbeat:.1f} s"
        return None

    def position_fresh(self, now: float, max_age_s: float) -> bool:
        return self.position_time is not None and now - self.position_time < max_age_s


def phase(v: WatchedVehicle, now: float, error_m: float | None, formation_radius_m: float,
          lost_text: str = "lost", arming: str = "") -> str:
    """What an operator would say the UAV is doing, for the log and /diagnostics:
    "waiting for heartbeat" | "lost" | `arming` when not "" (`ArmingSequence.phase()`:
    "failed: ..." or the readiness step) | "disarmed" | "armed" | "airborne" | "in formation"
    (within `formation_radius_m` of its target)."""
    if not v.linked:
        return lost_text if v.last_heartbeat is not None else "waiting for heartbeat"
    if arming:
        return arming
    if not v.armed:
        if v.prearm:
            return f"prearm: {v.prearm}"
        return v.position_ready(now, 2.0) or "disarmed"
    if error_m is not None and error_m <= formation_radius_m and v.airborne:
        return "in formation"
    return "airborne" if v.airborne else "armed"
