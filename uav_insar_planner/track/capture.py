"""Whether a UAV is captured at its start point: the test both pass starts make (the bridge's
own gate, mavlink/start_gate.py, and the planner's, ros/start_capture.py), each on the
positions it has."""
from __future__ import annotations

import math

from uav_insar_planner.plan import Vec3


def outside(position: Vec3, start: Vec3, radius_m: float) -> float | None:
    """How far `position` is from `start` when farther than `radius_m`, else None (captured;
    radius 0 captures everywhere). One frame for both points; a NaN distance is outside."""
    if radius_m <= 0.0:
        return None
    d = math.dist(position, start)
    return None if d <= radius_m else d  # (so written that NaN never counts as inside)
