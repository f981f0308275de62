"""The planner's one pass start for bridges that each fly one UAV (`formation/start`).

No per-UAV bridge sees the other vehicles, so none can tell when the formation is complete.
The planner can: it watches uav{K}/mavlink/pose of every UAV the current plan flies and the
swarm watch has not declared lost, and once each is fresh (younger than POSE_FRESH_S) and
within `capture_radius_m` (planner parameter, as the bridge's) of its start point
(x_k, y_start, z_k), it publishes ONE start, latched (ros/start_msgs.py): wall clock now +
`start_delay_s`, labelled with the plan's identity. Every bridge with pass_start "planner"
starts its pass at that instant; the hosts' clocks must agree (GNSS time, chrony), as an
offset dt puts a UAV v_y dt along track.

A plan with the same y_start as the started one (a re-plan during the pass) gets the same
instant again under its own identity, so the pass continues; one with another y_start (or the
hold plan, nothing flown) waits for a new capture. Radius 0 starts at the first check.

Each start is sent again every REPEAT_PERIOD_S until REPEAT_AFTER_S past its instant (and for
at least REPEAT_MIN_S): on a lossy radio a reliable sample that is lost is repaired only at
the writer's next heartbeat (3 s in Fast DDS), after the 2 s start_delay_s, so a bridge or
agent that lost it would join the pass late; a newer copy, sent half a second later, is there
in time. Receivers take the same instant again as no change.
"""
from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from std_msgs.msg import Header

from uav_insar_planner.ros import topics
from uav_insar_planner.ros.plan_msgs import PlanId
from uav_insar_planner.ros.start_msgs import encode_start
from uav_insar_planner.swarm import uav_name

CHECK_PERIOD_S = 0.1
# Bridges publish a pose per LOCAL_POSITION_NED, ~10 Hz: older than this is a silent UAV.
POSE_FRESH_S = 1.0
SAME_Y_START_M = 1e-3  # as trajectory.PassTrajectory: the same track start
REPEAT_PERIOD_S = 0.5
REPEAT_AFTER_S = 1.0
REPEAT_MIN_S = 2.0
# A capture that takes longer than this is said, with who is missing and why, this often: a
# copter's boot and climb take a minute, a vehicle that never arrives must not be silent.
WAIT_LOG_PERIOD_S = 15.0


Point = tuple[float, float, float]


def not_captured(starts: dict[int, Point], poses: dict[int, tuple[float, Point]],
                 now: float, radius_m: float) -> dict[int, str]:
    """Why each UAV of `starts` is not captured (no pose fresher than POSE_FRESH_S at `now`,
    monotonic, or farther than `radius_m` from its start), by UAV; empty when all are."""
    why: dict[int, str] = {}
    for k, start in starts.items():
        seen = poses.get(k)
        if seen is None:
            why[k] = f"no {topics.mavlink_pose(k)} yet"
        elif now - seen[0] > POSE_FRESH_S:
            why[k] = f"no {topics.mavlink_pose(k)} for {now - seen[0]:.1f} s"
        elif not (radius_m <= 0.0 or math.dist(seen[1], start) <= radius_m):
            # (written so that a NaN distance never counts as inside)
            why[k] = f"{math.dist(seen[1], start):.2f} m from its start point"
    return why


def all_captured(starts: dict[int, Point], poses: dict[int, tuple[float, Point]],
                 now: float, radius_m: float) -> bool:
    """Whether every UAV of `starts` has a pose (monotonic time, position) fresher than
    POSE_FRESH_S at `now` within `radius_m` of its start; False with nothing to start."""
    return bool(starts) and not not_captured(starts, poses, now, radius_m)


class PassStart:
    """See the module docstring. `lost()` is the set of UAVs the swarm watch declared lost;
    `node` has the parameters capture_radius_m and start_delay_s."""

    def __init__(self, node: Node, lost: Callable[[], set[int]]) -> None:
        self._node, self._lost = node, lost
        self._lock = threading.Lock()
        self._poses: dict[int, tuple[float, Point]] = {}
        self._plan: PlanId | None = None
        self._starts: dict[int, Point] = {}  # flown UAV -> its start point
        self._y_start: float | None = None
        self._start_ns: int | None = None  # the published instant, while this pass lasts
        self._repeat: tuple[Header, float, float] | None = None  # message, next, until (wall)
        self._wait_told = time.monotonic()  # the last time the wait for a capture was said
        self._pub = node.create_publisher(Header, topics.FORMATION_START, topics.LATCHED)
        node.create_timer(CHECK_PERIOD_S, self._check)

    def watch_uav(self, k: int) -> None:
        """Subscribe vehicle k's uav{k}/mavlink/pose (the planner calls it for each UAV)."""
        self._node.create_subscription(PoseStamped, topics.mavlink_pose(k),
                                       lambda msg, k=k: self._on_pose(k, msg), topics.DEPTH)

    def on_plan(self, plan_id: PlanId, points: Sequence[Point]) -> None:
        """The planner published plan `plan_id` with start points `points` (NaN: not flown)."""
        starts = {k: tuple(p) for k, p in enumerate(points) if all(map(math.isfinite, p))}
        y_start = next(iter(starts.values()))[1] if starts else None
        with self._lock:
            same = (self._start_ns is not None and y_start is not None
                    and abs(y_start - self._y_start) < SAME_Y_START_M)
            self._plan, self._starts, self._y_start = plan_id, starts, y_start
            self._wait_told = time.monotonic()
            if not same:
                self._start_ns, self._repeat = None, None  # the old pass's start is void
                return
            start_ns = self._start_ns
        self._publish(encode_start(start_ns, plan_id), start_ns)
        self._node.get_logger().info(f"pass continues: the same start again for {plan_id}")

    def _publish(self, msg: Header, start_ns: int) -> None:
        """Send a start now, and again every REPEAT_PERIOD_S (module doc)."""
        self._pub.publish(msg)
        now = time.time()
        until = max(start_ns * 1e-9 + REPEAT_AFTER_S, now + REPEAT_MIN_S)
        with self._lock:
            self._repeat = (msg, now + REPEAT_PERIOD_S, until)

    def _send_again(self) -> None:
        now = time.time()
        with self._lock:
            if self._repeat is None or now < self._repeat[1]:
                return
            msg, _, until = self._repeat
            self._repeat = (msg, now + REPEAT_PERIOD_S, until) if now < until else None
        self._pub.publish(msg)

    def _bridged(self, starts: dict[int, Point]) -> bool:
        """Whether a bridge flies any of `starts` (publishes its uavK/mavlink/pose): without
        one (self-flown agents) no pass start is awaited, and nothing is said."""
        return any(self._node.count_publishers(topics.mavlink_pose(k)) for k in starts)

    def _on_pose(self, k: int, msg: PoseStamped) -> None:
        p = msg.pose.position
        with self._lock:
            self._poses[k] = (time.monotonic(), (p.x, p.y, p.z))

    def _check(self) -> None:
        self._send_again()
        radius = float(self._node.get_parameter("capture_radius_m").value)
        delay = float(self._node.get_parameter("start_delay_s").value)
        lost = self._lost()
        with self._lock:
            if self._plan is None or self._start_ns is not None:
                return
            starts = {k: p for k, p in self._starts.items() if k not in lost}
            now = time.monotonic()
            if not all_captured(starts, self._poses, now, radius):
                why = (not_captured(starts, self._poses, now, radius)
                       if now - self._wait_told >= WAIT_LOG_PERIOD_S and self._bridged(starts)
                       else {})
                if why:
                    self._wait_told = now
                    waiting = ", ".join(f"{uav_name(k)} ({w})" for k, w in sorted(why.items()))
                    self._node.get_logger().info(f"the pass start waits for {waiting}: "
                                                 f"capture_radius_m {radius:g} ({self._plan})")
                return
            self._start_ns = time.time_ns() + round(delay * 1e9)
            start_ns, plan_id = self._start_ns, self._plan
        self._publish(encode_start(start_ns, plan_id), start_ns)
        self._node.get_logger().info(
            f"every flown UAV ({', '.join(uav_name(k) for k in sorted(starts))}) within "
            f"{radius:g} m of its start: the pass starts in {delay:g} s, wall clock "
            f"{start_ns * 1e-9:.3f} ({plan_id})")
