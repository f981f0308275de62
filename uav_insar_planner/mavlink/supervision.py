"""Link supervision: what the bridge knows of one vehicle from its heartbeats and positions.

A UAV is found on its first vehicle HEARTBEAT (one from a camera, GCS or companion on the same
sysid does not count), lost after `heartbeat_timeout_s` without one, and found again when one
returns. LOCAL_POSITION_NED is kept with the time it arrived.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from pymavlink import mavutil

from uav_insar_planner.mavlink.frames import Vec3
from uav_insar_planner.mavlink.link import MAV, Link

if TYPE_CHECKING:
    from uav_insar_planner.mavlink.sequencer import ArmingSequence

_NOT_VEHICLE_TYPES = frozenset((MAV.MAV_TYPE_GCS, MAV.MAV_TYPE_ONBOARD_CONTROLLER,
                                MAV.MAV_TYPE_GIMBAL, MAV.MAV_TYPE_ADSB, MAV.MAV_TYPE_CAMERA,
                                MAV.MAV_TYPE_ANTENNA_TRACKER))


def is_vehicle_heartbeat(msg: MAV.MAVLink_message) -> bool:
    """True for a HEARTBEAT from the autopilot itself."""
    return msg.type not in _NOT_VEHICLE_TYPES and msg.autopilot != MAV.MAV_AUTOPILOT_INVALID


@dataclass
class WatchedVehicle:
    """One UAV as the bridge sees it; `sequence` is its arming sequence (None: not run)."""

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
    sequence: ArmingSequence | None = None

    @property
    def link_state(self) -> str:
        """"waiting" (never heard) | "linked" | "lost"."""
        return "linked" if self.linked else (
            "lost" if self.last_heartbeat is not None else "waiting")

    @property
    def airborne(self) -> bool:
        return self.position_ned is not None and self.position_ned[2] < -0.5

    @property
    def sequence_active(self) -> bool:
        return self.sequence is not None and self.sequence.active

    @property
    def failed(self) -> bool:
        return self.sequence is not None and bool(self.sequence.failed)

    def on_heartbeat(self, msg: MAV.MAVLink_message, now: float) -> str | None:
        """Take a vehicle heartbeat; return the event text when the link is (re)found."""
        seen_before = self.last_heartbeat is not None
        self.compid = msg.get_srcComponent()
        self.last_heartbeat = now
        self.mode = mavutil.mode_string_v10(msg)
        self.custom_mode = msg.custom_mode
        self.armed = bool(msg.base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED)
        if self.linked:
            return None
        self.linked = True
        again = " again" if seen_before else ""
        return (f"sysid {self.sysid} found{again} ({self.mode}, "
                f"{'armed' if self.armed else 'disarmed'})")

    def on_position(self, msg: MAV.MAVLink_message, now: float) -> None:
        self.position_ned = (msg.x, msg.y, msg.z)
        self.position_time = now

    def check_timeout(self, now: float, timeout_s: float) -> str | None:
        """Mark the link lost after `timeout_s` of silence; return the event text if so."""
        if self.linked and now - self.last_heartbeat > timeout_s:
            self.linked = False
            return f"sysid {self.sysid} lost: no heartbeat for {now - self.last_heartbeat:.1f} s"
        return None

    def position_fresh(self, now: float, max_age_s: float) -> bool:
        return self.position_time is not None and now - self.position_time < max_age_s
