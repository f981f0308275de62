"""When the bridge's pass starts: every UAV of the gate captured at its start point, or the
planner's instant.

pass_start "capture": a bridge that sees every vehicle starts the pass itself once each
linked UAV with a target (whose arming did not fail) reports a fresh position within
`capture_radius_m` of its entry, the start of its run-in (track.capture,
track.trajectory); radius 0 starts at once.
pass_start "planner" (a stack per UAV: no bridge sees the others): the planner sees every UAV
captured and publishes one wall-clock start a little in the future (ros/formation_start.py);
`planner_start` flies it on the bridge's monotonic clock (track.trajectory.PassTrajectory
.start_from), so every bridge starts at the same instant as far as the hosts' clocks agree
(GNSS time / chrony: an offset dt puts a UAV v_y dt along track).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

from uav_insar_planner.mavlink.config import BridgeConfig
from uav_insar_planner.mavlink.sequencer import ArmingSequence
from uav_insar_planner.mavlink.supervision import WatchedVehicle
from uav_insar_planner.track.capture import outside
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.trajectory import PassTrajectory


def captured(gate: Sequence[WatchedVehicle], pass_: PassTrajectory, frame: TrackFrame,
             now: float, capture_radius_m: float, max_age_s: float) -> bool:
    """True when every vehicle of `gate` is captured (see the module doc); never with an
    empty gate unless the radius is 0."""
    if capture_radius_m <= 0.0:
        return True
    if not gate:
        return False
    for v in gate:
        if not v.position_fresh(now, max_age_s):
            return False
        if outside(v.position_ned, frame.to_ned(*pass_.entry(v.uav)),
                   capture_radius_m) is not None:
            return False
    return True


def capture_start(vehicles: Sequence[WatchedVehicle], sequences: Mapping[int, ArmingSequence],
                  pass_: PassTrajectory, frame: TrackFrame, now: float,
                  config: BridgeConfig) -> bool:
    """pass_start "capture": start the track of `pass_` at `now` (True) when the gate, every
    linked vehicle with a target whose arming (`sequences`) did not fail, is `captured`."""
    if (pass_.clock is not None or pass_.formation is None
            or config.pass_start == "planner"):
        return False
    gate = [v for v in vehicles if pass_.start_pose(v.uav) is not None and v.linked
            and not (v.uav in sequences and sequences[v.uav].failed)]
    if not captured(gate, pass_, frame, now, config.capture_radius_m,
                    config.heartbeat_timeout_s):
        return False
    pass_.start_now(now)
    return True


def planner_start(pass_: PassTrajectory, wall_time_s: float, mono_now: float,
                  wall_now: float, label: str, offset_m: float = 0.0) -> str:
    """Fly the planner's start at the wall-clock instant `wall_time_s` (read against
    `wall_now`, time.time(), at monotonic `mono_now`), the pass `offset_m` past its start
    line then (a resumed pass); the event text, "" when nothing changed (no formation yet,
    or the same start again)."""
    if pass_.formation is None:
        return ""
    sent = pass_.start_from(wall_time_s, offset_m, mono_now, wall_now)
    if sent is None:
        return ""
    return f"pass start from the planner ({label}): {sent.describe(wall_now)}"


def lags(vehicles: Sequence[WatchedVehicle], pass_: PassTrajectory, frame: TrackFrame,
         now: float) -> dict[int, float | None]:
    """How far each vehicle's target is ahead of it along track at `now` (metres; 0 before
    the pass runs, when the target is its start point and no pass is yet to be kept; None
    without a target or a position)."""
    out: dict[int, float | None] = {}
    for v in vehicles:
        target = pass_.target(v.uav, now)
        if target is None or v.position_ned is None:
            out[v.uav] = None
        elif not pass_.running(now):
            out[v.uav] = 0.0
        else:
            out[v.uav] = target[0][1] - frame.from_ned(*v.position_ned)[1]
    return out


def resume_where_held(pass_: PassTrajectory, held_lags: Sequence[float | None]) -> str:
    """pass_start "capture" (the bridge's own clock, every vehicle its own): move the track
    clock later so that the rearmost held vehicle's target is where it stands (`held_lags`:
    the held vehicles' `lags`), and the swarm goes on from there at the planned speed; the
    event text, "" when nothing moved."""
    behind = [lag for lag in held_lags if lag is not None]
    if pass_.clock is None or not behind or max(behind) <= 0.0 or pass_.speed_mps <= 0.0:
        return ""
    shift = max(behind) / pass_.speed_mps
    pass_.clock = pass_.clock.shifted(shift)
    return (f"the pass resumes where the swarm holds: its clock {shift:.2f} s later "
            f"({max(behind):.2f} m)")
