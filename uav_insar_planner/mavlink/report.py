"""What the bridge reports: events worth a log line and one snapshot per UAV (`vehicle_status`)."""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from uav_insar_planner.mavlink.sequencer import ArmingSequence
from uav_insar_planner.mavlink.supervision import WatchedVehicle, phase
from uav_insar_planner.plan import Vec3
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.trajectory import PassTrajectory

# The bridge's event sink (uav or -1 for the swarm, level, text): what becomes a BridgeEvent.
Emit = Callable[[int, str, str], None]


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
    pass_plan: str = ""  # the plan whose pass start the track clock is ("": none, capture)
    # that start's wall-clock instant (time.time()), as the planner sent it: its confirmation
    # that this bridge flies the planner's latest start (ros/start_confirmations.py)
    pass_start_s: float | None = None
    behind: str = ""  # held and too far behind its target to rejoin: why ("" otherwise)
    # left our control (control_states): `out of our control: <mode>` ("" otherwise)
    out_of_control: str = ""


def vehicle_status(v: WatchedVehicle, now: float, pass_: PassTrajectory, frame: TrackFrame,
                   capture_radius_m: float, seq: ArmingSequence | None,
                   separation: str) -> VehicleStatus:
    """The snapshot of vehicle `v` at `now` under the pass `pass_` (its arming sequence `seq`,
    None when it has none)."""
    target = pass_.target(v.uav, now)
    track = None if v.position_ned is None else frame.from_ned(*v.position_ned)
    error = None if track is None or target is None else math.dist(track, target[0])
    radius = capture_radius_m if capture_radius_m > 0 else 1.0
    return VehicleStatus(
        uav=v.uav, sysid=v.sysid, compid=v.compid, connection=v.link.address,
        link=v.link_state,
        heartbeat_age_s=None if v.last_heartbeat is None else now - v.last_heartbeat,
        mode=v.mode, armed=v.armed,
        position_track=track,
        position_ned=v.position_ned,
        position_age_s=None if v.position_time is None else now - v.position_time,
        target_track=None if target is None else target[0], setpoints_sent=v.setpoints_sent,
        sequence="off" if seq is None else seq.text(), last_ack=v.last_ack,
        phase=phase(v, now, error, radius, arming=seq.phase() if seq else ""),
        prearm=v.prearm, link_up=v.link.up, separation=separation)
