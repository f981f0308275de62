"""Where the UAVs are for the planner's pass start (ros/formation_start.py), from the poses
their bridges publish: each captured at its entry (the start of its run-in,
track/trajectory.py), or (a planner started again) all on their tracks past the start line,
and the rearmost of them.

Poses are (monotonic time heard, (x, y, z) in the track frame) per UAV; a start point is
(x_k, y_start, z_k), an entry (x_k, y_start - run_in, z_k). The capture test is the bridge's
(track/capture.py).
"""
from __future__ import annotations

import math
from collections.abc import Mapping

from uav_insar_planner.plan import Vec3
from uav_insar_planner.ros import topics
from uav_insar_planner.track.capture import outside
from uav_insar_planner.track.passes import run_in_m

# Bridges publish a pose per LOCAL_POSITION_NED, ~10 Hz: older than this is a silent UAV.
POSE_FRESH_S = 1.0
ON_TRACK_M = 2.0  # a held copter drifts in wind: wider than the default capture radius


def not_captured(starts: dict[int, Vec3], poses: dict[int, tuple[float, Vec3]],
                 now: float, radius_m: float) -> dict[int, str]:
    """Why each UAV of `starts` (its capture point: the entry) is not captured (no pose
    fresher than POSE_FRESH_S at `now`, monotonic, or farther than `radius_m` from it), by
    UAV; empty when all are."""
    why: dict[int, str] = {}
    for k, start in starts.items():
        seen = poses.get(k)
        if seen is None:
            why[k] = f"no {topics.mavlink_pose(k)} yet"
        elif now - seen[0] > POSE_FRESH_S:
            why[k] = f"no {topics.mavlink_pose(k)} for {now - seen[0]:.1f} s"
        elif (far := outside(seen[1], start, radius_m)) is not None:
            why[k] = f"{far:.2f} m from its entry"
    return why


def on_track(starts: dict[int, Vec3], poses: dict[int, tuple[float, Vec3]],
              speeds: dict[int, float], now: float, length_m: float
              ) -> tuple[int, float, float] | None:
    """(rearmost UAV, its distance past the start line, its along-track speed) when every UAV
    of `starts` is fresh, within ON_TRACK_M of its track line and between its start line
    (ON_TRACK_M past it) and the end of the pass (`length_m`); None otherwise."""
    past: dict[int, float] = {}
    for k, (x0, y0, z0) in starts.items():
        seen = poses.get(k)
        if seen is None or now - seen[0] > POSE_FRESH_S:
            return None
        x, y, z = seen[1]
        if not (math.hypot(x - x0, z - z0) <= ON_TRACK_M and ON_TRACK_M < y - y0 < length_m):
            return None
        past[k] = y - y0
    if not past:
        return None
    rear = min(past, key=past.__getitem__)
    return rear, past[rear], speeds.get(rear, 0.0)


def all_captured(starts: dict[int, Vec3], poses: dict[int, tuple[float, Vec3]],
                 now: float, radius_m: float) -> bool:
    """Whether every UAV of `starts` has a pose (monotonic time, position) fresher than
    POSE_FRESH_S at `now` within `radius_m` of its start; False with nothing to start."""
    return bool(starts) and not not_captured(starts, poses, now, radius_m)


def why_not(entries: dict[int, Vec3], poses: dict[int, tuple[float, Vec3]], now: float,
            radius_m: float, bridge_speeds: Mapping[int, float], speed_mps: float
            ) -> dict[int, str]:
    """`not_captured`, by UAV in order, each with its bridge's other v_y (`other_speed`)."""
    why = not_captured(entries, poses, now, radius_m)
    return {k: w + other_speed(bridge_speeds.get(k), speed_mps) for k, w in sorted(why.items())}


def other_speed(theirs: float | None, ours: float) -> str:
    """Why a UAV may never reach the entry the planner waits for: its bridge flies another
    v_y (`theirs`, None: not said), so its entry (the run-in is the speed's) lies elsewhere
    ("" when it does not)."""
    if theirs is None or abs(theirs - ours) < 1e-6:
        return ""
    return (f"; its bridge flies speed_mps {theirs:g}, the plan {ours:g} m/s, so its entry is "
            f"{abs(run_in_m(theirs) - run_in_m(ours)):.2f} m from the one awaited")
