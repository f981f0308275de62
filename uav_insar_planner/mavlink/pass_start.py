"""When the pass may start: every UAV of the gate captured at its start point.

A bridge that sees every vehicle starts the pass itself once each linked UAV with a target
(whose arming did not fail) reports a fresh position within `capture_radius_m` of its start
point; radius 0 starts at once.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

from uav_insar_planner.mavlink.frames import TrackFrame
from uav_insar_planner.mavlink.supervision import WatchedVehicle
from uav_insar_planner.mavlink.trajectory import PassTrajectory


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
        start = frame.to_ned(*pass_.start_pose(v.uav))
        if not math.dist(start, v.position_ned) <= capture_radius_m:
            return False  # (written so that a NaN distance never counts as inside)
    return True
