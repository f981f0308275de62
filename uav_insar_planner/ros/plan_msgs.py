"""A Plan on the wire: `formation` (PoseArray) and `formation/power` (Float64MultiArray).

Identity. Every plan the planner publishes has one identity, `PlanId` = (planner, stamp):
  formation        header.stamp = the plan's stamp (strictly increasing per planner);
  formation/power  layout.dim = [("uav", K, K*N), ("slot", N, N), ("plan <planner> <s>.<ns>",
                   1, 1)]: a trailing dimension of size 1 whose label carries the identity,
                   e.g. `plan /planner 1733086200.123456789`. [K, N, 1] is the same row-major
                   data as [K, N], so readers of dims 0-1 are unchanged.
rclpy 7.1 tells a subscriber nothing per message about its publisher (message_info has the
source/received timestamps and sequence numbers, no publisher GID or node), so the formation
names no planner: a formation belongs to the plan whose power message carries the same stamp,
and the planner that plan names must be the sole publisher of both topics in the ROS graph for
a consumer to adopt it (ros/plan_gate.py).

A survey strip (track/leg.py) rides in the formation's header.frame_id, readable in `ros2
topic echo /formation` and recorded with the plan, so a bag says which strip each plan (and
so each slot) flew; degrees only here, at the edge:
  insar_track       a single pass, in the frame each node was configured with (an empty
                    frame_id, as a hand-published message has, too)
  insar_track: strip 3, sortie 1, attempt 1, last; heading 90.0000 deg; origin N 12.345
  E -67.890 D 0.000 m; length 120.000 m; station N 0.000 E 0.000 m     (one line; the
                    station optional) strip and sortie from 0 as in
                    survey.json, the strip's attempt (from 1: an interrupted strip is flown
                    again), `last` for the sortie's last strip, the strip frame about the home
                    (heading from north, origin in the home's NED), the imaged length, the
                    ground station (north, east about the home)

Validation (every decode; a bad message raises `PlanMessageError` naming topic, field, value
cut short and what is allowed, and the caller drops it without any change of state):
  formation  each pose's x, y, z finite with |v| <= POSITION_BOUND_M (1e6 m, well inside
             float32, which MAVLink carries), or a UAV not flown: x and z both NaN (y, the
             track start, may be finite or NaN); MIN_UAVS to MAX_UAVS poses (swarm.py: a
             swarm of 2 to 10, one pose per UAV, NaN for a UAV not flown); the quaternion is
             ignored; the frame_id one of the two above, its heading in [0, 360) deg,
             origin within POSITION_BOUND_M and length in (0, POSITION_BOUND_M] m;
  power      exactly the three dimensions above (MIN_UAVS to MAX_UAVS rows, slots >= 1,
             strides row-major, data_offset 0, a parseable identity label), len(data) = K*N,
             every value finite, >= 0 and at most FLOAT32_MAX W.
"""
from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, PoseArray, Quaternion
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from uav_insar_planner import published
from uav_insar_planner.mavlink.guard import FLOAT32_MAX
from uav_insar_planner.plan import Plan
from uav_insar_planner.ros import topics
from uav_insar_planner.swarm import MAX_UAVS, MIN_UAVS, uav_name
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.leg import SurveyLeg

POSITION_BOUND_M = 1e6
SHOWN_CHARS = 40
DROP_LOG_PERIOD_S = 1.0  # bad messages of these topics: at most a line a second (DropLog)
_ID_LABEL = re.compile(r"^plan (/\S*) (\d{1,12})\.(\d{9})$")
_NUMBER = r"(-?\d{1,7}\.\d{1,9})"
_LEG = re.compile(
    rf"^{re.escape(topics.FRAME_ID)}: strip (\d{{1,6}}), sortie (\d{{1,6}}), attempt (\d{{1,6}})"
    rf"(, last)?; heading "
    rf"{_NUMBER} deg; origin N {_NUMBER} E {_NUMBER} D {_NUMBER} m; length {_NUMBER} m"
    rf"(?:; station N {_NUMBER} E {_NUMBER} m)?$")


class PlanMessageError(ValueError):
    """One line: `<topic>: <field>: value <v> is not allowed; expected <what>`."""

    def __init__(self, topic: str, field: str, value: object, expected: str) -> None:
        shown = repr(value)
        if len(shown) > SHOWN_CHARS:
            shown = shown[:SHOWN_CHARS - 3] + "..."
        super().__init__(f"{topic}: {field}: value {shown} is not allowed; expected {expected}")
        self.topic, self.field = topic, field


@dataclass(frozen=True)
class PlanId:
    """A plan's identity: its stamp (sec, nanosec) and the planner's fully qualified name."""

    sec: int
    nanosec: int
    planner: str

    @property
    def stamp(self) -> tuple[int, int]:
        return self.sec, self.nanosec

    @property
    def label(self) -> str:
        return f"plan {self.planner} {self.sec}.{self.nanosec:09d}"

    def __str__(self) -> str:
        return self.label

    @classmethod
    def from_label(cls, label: str) -> PlanId | None:
        found = _ID_LABEL.match(label)
        if found is None:
            return None
        return cls(int(found[2]), int(found[3]), found[1])


@dataclass(frozen=True)
class Formation:
    """A decoded `formation`: its stamp, poses[k] = (x, y, z) or None for a UAV not flown, and
    the survey strip it flies (None: a single pass)."""

    stamp: tuple[int, int]
    points: tuple[tuple[float, float, float] | None, ...]
    leg: SurveyLeg | None = None


@dataclass(frozen=True)
class PowerSchedule:
    """A decoded `formation/power`: its plan id and P_com[k][n] in watts, shape (K, N)."""

    plan_id: PlanId
    p_com_w: np.ndarray


def next_stamp(now: tuple[int, int], last: tuple[int, int] | None) -> tuple[int, int]:
    """`now`, or 1 ns after `last` when the clock has not moved past it: stamps are unique and
    increasing per planner, so (planner, stamp) names one plan."""
    if last is None or now > last:
        return now
    sec, nanosec = last[0], last[1] + 1
    return (sec + 1, 0) if nanosec >= 1_000_000_000 else (sec, nanosec)


def encode_leg(leg: SurveyLeg | None) -> str:
    """The frame_id of a formation flown on `leg` (None: a single pass; module docstring)."""
    if leg is None:
        return topics.FRAME_ID
    n, e, d = leg.frame.origin_ned
    heading = math.degrees(leg.frame.bearing_rad) % 360.0
    return (f"{topics.FRAME_ID}: strip {leg.strip}, sortie {leg.sortie}, attempt {leg.attempt}"
            f"{', last' if leg.last else ''}; heading {heading:.4f} deg; "
            f"origin N {n:.3f} E {e:.3f} D {d:.3f} m; length {leg.length_m:.3f} m"
            + ("" if leg.station_ne_m is None else
               "; station N {:.3f} E {:.3f} m".format(*leg.station_ne_m)))


def decode_leg(frame_id: str) -> SurveyLeg | None:
    """The strip a formation's frame_id names, None for a single pass, or PlanMessageError."""
    if frame_id in (topics.FRAME_ID, ""):
        return None
    found = _LEG.match(frame_id)
    if found is None:
        raise PlanMessageError(topics.FORMATION, "header.frame_id", frame_id, (
            f"'{topics.FRAME_ID}', or '{topics.FRAME_ID}: strip <i>, sortie <j>, attempt <a>"
            "[, last]; "
            "heading <deg> deg; origin N <m> E <m> D <m> m; length <m> m[; station N <m> E "
            "<m> m]'"))
    heading, n, e, d, length = (float(v) for v in found.groups()[4:9])
    station = None if found[10] is None else (float(found[10]), float(found[11]))
    if int(found[3]) < 1 or not (0.0 <= heading < 360.0 and 0.0 < length <= POSITION_BOUND_M
                                 and max(abs(n), abs(e), abs(d), *map(abs, station or ()))
                                 <= POSITION_BOUND_M):
        raise PlanMessageError(topics.FORMATION, "header.frame_id", frame_id,
                               f"an attempt >= 1, a heading in [0, 360) deg, an origin within "
                               f"+-{POSITION_BOUND_M:g} m and a length in (0, "
                               f"{POSITION_BOUND_M:g}] m")
    return SurveyLeg(int(found[1]), int(found[2]), found[4] is not None,
                     TrackFrame(math.radians(heading), (n, e, d)), length, int(found[3]),
                     station)


def encode(points: Sequence[tuple[float, float, float]], plan: Plan, plan_id: PlanId,
           leg: SurveyLeg | None = None) -> tuple[PoseArray, Float64MultiArray]:
    """The two messages of `plan` under `plan_id` (see the module docstring), flown on `leg`
    (None: a single pass); `points` are its `published.formation_points`, which the planner
    also hands the pass start."""
    formation = PoseArray()
    formation.header.stamp = Time(sec=plan_id.sec, nanosec=plan_id.nanosec)
    formation.header.frame_id = encode_leg(leg)
    formation.poses = [Pose(position=Point(x=x, y=y, z=z), orientation=Quaternion(w=1.0))
                       for x, y, z in points]
    rows, cols, data = published.power_rows(plan)
    power = Float64MultiArray(data=data)
    power.layout.dim = [MultiArrayDimension(label="uav", size=rows, stride=rows * cols),
                        MultiArrayDimension(label="slot", size=cols, stride=cols),
                        MultiArrayDimension(label=plan_id.label, size=1, stride=1)]
    return formation, power


def decode_formation(msg: PoseArray) -> Formation:
    """Validated `formation`, or PlanMessageError."""
    poses = msg.poses
    if not MIN_UAVS <= len(poses) <= MAX_UAVS:
        raise PlanMessageError(topics.FORMATION, "poses", f"{len(poses)} poses",
                               f"{MIN_UAVS} to {MAX_UAVS} poses, one per UAV")
    points: list[tuple[float, float, float] | None] = []
    for k, pose in enumerate(poses):
        p = pose.position
        xyz = (float(p.x), float(p.y), float(p.z))
        if math.isnan(xyz[0]) and math.isnan(xyz[2]):
            _check_position(k, "y", xyz[1], nan_ok=True)
            points.append(None)
            continue
        for axis, v in zip("xyz", xyz, strict=True):
            _check_position(k, axis, v, nan_ok=False)
        points.append(xyz)
    stamp = msg.header.stamp
    return Formation((int(stamp.sec), int(stamp.nanosec)), tuple(points),
                     decode_leg(msg.header.frame_id))


def _check_position(k: int, axis: str, v: float, nan_ok: bool) -> None:
    if (nan_ok and math.isnan(v)) or (math.isfinite(v) and abs(v) <= POSITION_BOUND_M):
        return
    expected = (f"a finite coordinate within +-{POSITION_BOUND_M:g} m, or x and z both NaN "
                "for a UAV not flown")
    raise PlanMessageError(topics.FORMATION, f"poses[{k}].position.{axis}", v, expected)


def decode_power(msg: Float64MultiArray) -> PowerSchedule:
    """Validated `formation/power`, or PlanMessageError."""
    dims = msg.layout.dim

    def bad(field: str, value: object, expected: str) -> PlanMessageError:
        return PlanMessageError(topics.POWER, field, value, expected)

    if len(dims) != 3:
        raise bad("layout.dim", [d.label for d in dims],
                  "3 dimensions: uav, slot, plan identity")
    uav, slot, ident = dims
    plan_id = PlanId.from_label(ident.label)
    if plan_id is None:
        raise bad("layout.dim[2].label", ident.label, "'plan <planner> <sec>.<nanosec>'")
    if (uav.label, slot.label) != ("uav", "slot"):
        raise bad("layout.dim labels", [uav.label, slot.label], "['uav', 'slot']")
    rows, cols = int(uav.size), int(slot.size)
    if not MIN_UAVS <= rows <= MAX_UAVS or cols < 1 or ident.size != 1:
        raise bad("layout.dim sizes", [rows, cols, int(ident.size)],
                  f"[{MIN_UAVS}..{MAX_UAVS} UAVs, >= 1 slots, 1]")
    if (uav.stride, slot.stride, ident.stride) != (rows * cols, cols, 1):
        raise bad("layout.dim strides", [uav.stride, slot.stride, ident.stride],
                  f"row-major [{rows * cols}, {cols}, 1]")
    if msg.layout.data_offset != 0:
        raise bad("layout.data_offset", msg.layout.data_offset, "0")
    data = np.asarray(msg.data, dtype=float)
    if data.size != rows * cols:
        raise bad("data", f"{data.size} values", f"uav x slot = {rows * cols} values")
    wrong = ~(np.isfinite(data) & (data >= 0.0) & (data <= FLOAT32_MAX))
    if wrong.any():
        i = int(np.flatnonzero(wrong)[0])
        raise bad(f"data[{i}]", float(data[i]), f"a finite power >= 0 W, at most {FLOAT32_MAX:g}")
    return PowerSchedule(plan_id, data.reshape(rows, cols))


def describe(points: Sequence[tuple[float, float, float] | None]) -> str:
    """'uav0 (x, z), uav1 (x, z), uav2 not flown' for a log line."""
    return ", ".join(f"{uav_name(k)} not flown" if p is None
                     else f"{uav_name(k)} ({p[0]:.3f}, {p[2]:.3f})" for k, p in enumerate(points))
