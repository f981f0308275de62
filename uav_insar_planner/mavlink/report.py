"""What the bridge reports: events worth a log line and one snapshot per UAV."""
from __future__ import annotations

from dataclasses import dataclass

from uav_insar_planner.mavlink.frames import Vec3


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
    phase: str = ""  # see supervision.phase
    prearm: str = ""  # the latest arming refusal reason the vehicle sent
    link_up: bool = True  # False while its TCP link is (re)connecting
    separation: str = ""  # "" or why this UAV is planned too close to another
