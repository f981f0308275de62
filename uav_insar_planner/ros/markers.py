"""The planner's markers for RViz and Foxglove (visualization_msgs), frame `insar_track`.

`formation/markers` (MarkerArray, latched like `formation`): one DELETEALL first (a new plan
replaces the old one, even with fewer UAVs), then, per namespace, so that each can be toggled:

  planned         SPHERE per flown UAV k (id k) at its planned (x_k, 0, z_k), 1 m
  labels          TEXT_VIEW_FACING per UAV (id k): "U0 master", "U1 slave", ...
  beam            TRIANGLE_LIST per UAV (id k): the -3 dB beam from the UAV to its swath, at y=0
  swath           CUBE per UAV (id k): the ground swath along the whole track, 0.1 m thick
  target_line     LINE_STRIP (id 0): x = x_t on the ground, along the track
  ground_station  CUBE (id 0), 2 m, at g
  comm_disk       CYLINDER per UAV (id k): its C9-C11 disk of radius rho_k around g in the x-z
                  plane (axis along y, 0.2 m thick); none when rho_k is not finite

UAV colours: swarm.uav_rgb, as in every plot (`uav-insar plot-formation`): U0 red, U1 blue,
U2 green, then the slaves of larger swarms; geometry from report/scene.py.
`formation/markers/flown` (MarkerArray, depth 10, at most every FLOWN_PERIOD_S): per UAV that
reported a pose, `actual` SPHERE (id k) at its latest uav{K}/pose and `flown` LINE_STRIP
(id k), the path flown, a point every TRAIL_STEP_M, at most TRAIL_POINTS.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Quaternion, Vector3
from rclpy.node import Node
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from uav_insar_planner.params import Params
from uav_insar_planner.plan import Plan, Vec3
from uav_insar_planner.report.scene import Scene, scene
from uav_insar_planner.ros import topics
from uav_insar_planner.swarm import uav_rgb

FLOWN_PERIOD_S = 0.2
TRAIL_STEP_M = 0.5
TRAIL_POINTS = 5000
_ALONG_Y = Quaternion(x=math.sqrt(0.5), w=math.sqrt(0.5))  # a cylinder's z axis onto y


def _rgba(rgb: tuple[float, float, float], alpha: float = 1.0) -> ColorRGBA:
    return ColorRGBA(r=rgb[0], g=rgb[1], b=rgb[2], a=alpha)


def _point(p: Vec3) -> Point:
    return Point(x=float(p[0]), y=float(p[1]), z=float(p[2]))


def _marker(stamp: Time, ns: str, mid: int, kind: int, rgba: ColorRGBA,
            scale: tuple[float, float, float], position: Vec3 = (0.0, 0.0, 0.0)) -> Marker:
    m = Marker(ns=ns, id=mid, type=kind, action=Marker.ADD, color=rgba,
               scale=Vector3(x=scale[0], y=scale[1], z=scale[2]))
    m.header.stamp = stamp
    m.header.frame_id = topics.FRAME_ID
    m.pose.position = _point(position)
    m.pose.orientation.w = 1.0
    return m


def plan_markers(s: Scene, stamp: Time) -> MarkerArray:
    """The `formation/markers` array of scene `s` (see the module docstring)."""
    clear = Marker(action=Marker.DELETEALL)
    clear.header.stamp, clear.header.frame_id = stamp, topics.FRAME_ID
    out = [clear]
    y0, y1 = s.track_y
    for u in s.uavs:
        rgb = uav_rgb(u.k)
        x, _, z = u.position
        out.append(_marker(stamp, "planned", u.k, Marker.SPHERE, _rgba(rgb), (1.0, 1.0, 1.0),
                           u.position))
        label = _marker(stamp, "labels", u.k, Marker.TEXT_VIEW_FACING, _rgba(rgb), (0, 0, 1.5),
                        (x, 0.0, z + 2.0))
        label.text = f"U{u.k} {'master' if u.k == 0 else 'slave'}"
        out.append(label)
        beam = _marker(stamp, "beam", u.k, Marker.TRIANGLE_LIST, _rgba(rgb, 0.25),
                       (1.0, 1.0, 1.0))
        beam.points = [_point(u.position), _point((u.swath_x[0], 0.0, 0.0)),
                       _point((u.swath_x[1], 0.0, 0.0))]
        out.append(beam)
        lo, hi = u.swath_x
        out.append(_marker(stamp, "swath", u.k, Marker.CUBE, _rgba(rgb, 0.3),
                           (hi - lo, y1 - y0, 0.1), ((lo + hi) / 2, (y0 + y1) / 2, 0.05)))
        if math.isfinite(u.disk_radius):
            disk = _marker(stamp, "comm_disk", u.k, Marker.CYLINDER, _rgba(rgb, 0.15),
                           (2 * u.disk_radius, 2 * u.disk_radius, 0.2), s.station)
            disk.pose.orientation = _ALONG_Y
            out.append(disk)
    line = _marker(stamp, "target_line", 0, Marker.LINE_STRIP, _rgba((0.1, 0.1, 0.1)),
                   (0.3, 0.0, 0.0))
    line.points = [_point((s.x_t, y0, 0.0)), _point((s.x_t, y1, 0.0))]
    out.append(line)
    out.append(_marker(stamp, "ground_station", 0, Marker.CUBE, _rgba((0.3, 0.3, 0.3)),
                       (2.0, 2.0, 2.0), s.station))
    return MarkerArray(markers=out)


class FlownTrail:
    """The agents' positions as markers: `update(k, position)` keeps the path; `markers(stamp)`
    is the `formation/markers/flown` array (see the module docstring)."""

    def __init__(self) -> None:
        self.latest: dict[int, Vec3] = {}
        self.trails: dict[int, list[Vec3]] = {}

    def update(self, k: int, position: Vec3) -> None:
        self.latest[k] = position
        trail = self.trails.setdefault(k, [])
        if not trail or math.dist(trail[-1], position) >= TRAIL_STEP_M:
            trail.append(position)
            del trail[:-TRAIL_POINTS]

    def markers(self, stamp: Time) -> MarkerArray:
        out = []
        for k, position in sorted(self.latest.items()):
            rgb = uav_rgb(k)
            out.append(_marker(stamp, "actual", k, Marker.SPHERE, _rgba(rgb, 0.8),
                               (0.8, 0.8, 0.8), position))
            path = _marker(stamp, "flown", k, Marker.LINE_STRIP, _rgba(rgb, 0.8),
                           (0.15, 0.0, 0.0))
            path.points = [_point(p) for p in self.trails[k] + [position]]
            out.append(path)
        return MarkerArray(markers=out)


class PlannerMarkers:
    """The planner's two marker publishers: `publish_plan(params, plan)` after each plan,
    `on_pose(k, msg)` for each uav{K}/pose (published at most every FLOWN_PERIOD_S)."""

    def __init__(self, node: Node, clock: Callable[[], float] = time.monotonic) -> None:
        self._node = node
        self._clock = clock
        self._plan_pub = node.create_publisher(MarkerArray, topics.MARKERS, topics.LATCHED)
        self._flown_pub = node.create_publisher(MarkerArray, topics.FLOWN_MARKERS, topics.DEPTH)
        self.trail = FlownTrail()
        self._last = -math.inf

    def _stamp(self) -> Time:
        return self._node.get_clock().now().to_msg()

    def publish_plan(self, params: Params, plan: Plan) -> None:
        self._plan_pub.publish(plan_markers(scene(params, plan), self._stamp()))

    def on_pose(self, k: int, msg: Any) -> None:
        p = msg.pose.position
        self.trail.update(k, (p.x, p.y, p.z))
        now = self._clock()
        if now - self._last >= FLOWN_PERIOD_S:
            self._last = now
            self._flown_pub.publish(self.trail.markers(self._stamp()))
