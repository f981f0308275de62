"""The planner's one start of the pass for the whole formation (`formation/start`), for
bridges that each fly one UAV (their side: mavlink/pass_clock.py's `planner_start`).

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

A pass that cannot go on from its clock resumes where the swarm is, with an explicit start
(`encode_start` with an offset: the targets hold at that distance past the start line until
the instant, then fly on at v_y; never a catch-up to an old clock):
- a planner started again finds the UAVs on their tracks past the start line (each fresh,
  within ON_TRACK_M across track and height of its line, before the end of the pass;
  ros/start_capture.py, as the capture above): the
  pass resumes from the rearmost UAV, at once if the swarm is still flying the dead planner's
  clock (moving at more than half v_y), else after `start_delay_s` and at least
  RESTARTED_DELAY_S (every bridge must find the new planner first). Said in one line.
- every flown UAV's bridge reports it `behind` on this planner's pass (held by a ground
  silence, too far behind its target to rejoin, e.g. this planner froze): the same resume.
- either way from the hover, the start waits for every flown UAV's bridge to confirm it on
  /diagnostics, and is moved later while one has not (ros/start_confirmations.py).
- some, not all, report it for longer than BEHIND_GRACE_S: each is declared lost
  (`declare_lost`) and the swarm watch replans without it, as for a lost UAV.

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
from collections import deque
from collections.abc import Callable, Sequence

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from std_msgs.msg import Header

from uav_insar_planner import published
from uav_insar_planner.ros import start_confirmations, topics
from uav_insar_planner.ros.plan_msgs import PlanId
from uav_insar_planner.ros.start_capture import (
    POSE_FRESH_S,
    Point,
    all_captured,
    not_captured,
    on_track,
)
from uav_insar_planner.ros.start_confirmations import (
    GIVE_UP,
    LATER,
    REPORT_FRESH_S,
    WAIT,
    AwaitedStart,
)
from uav_insar_planner.ros.start_msgs import encode_start
from uav_insar_planner.swarm import uav_name

CHECK_PERIOD_S = 0.1
SAME_Y_START_M = 1e-3  # as trajectory.PassTrajectory: the same track start
REPEAT_PERIOD_S = 0.5
REPEAT_AFTER_S = 1.0
REPEAT_MIN_S = 3.0
SPEED_WINDOW_S = 1.0  # along-track speed from the poses of the last second
# Bridges say `behind` once a second on /diagnostics; a swarm held by one silence says it
# within a few seconds of each other, DDS repairs included. Longer alone: it is left behind.
BEHIND_GRACE_S = 4.0
# A swarm still flying is resumed on an instant this far in the past (more than the bridges'
# trajectory.JOIN_GRACE_S): they take it as a running pass and do not ramp up from a hover.
MOVING_BACKDATE_S = 1.0
# A planner started again hears the UAVs' poses before every bridge has found it (DDS
# discovers each direction on its own): a resume from the hover then starts no sooner than
# this. A CI run at 10 % loss: a bridge heard the new planner's start 3.4 s after it was sent,
# too late for start_delay_s 2 s, and its UAV, 6 m behind a target already moving, was lost.
RESTARTED_DELAY_S = 5.0
# A capture that takes longer than this is said, with who is missing and why, this often: a
# copter's boot and climb take a minute, a vehicle that never arrives must not be silent.
WAIT_LOG_PERIOD_S = 15.0


class FormationStart:
    """See the module docstring. `lost()` is the set of UAVs the swarm watch declared lost;
    `node` has the parameters capture_radius_m, start_delay_s and start_confirm_wait_s."""

    def __init__(self, node: Node, lost: Callable[[], set[int]],
                 declare_lost: Callable[[int, str], None]) -> None:
        self._node, self._lost, self._declare_lost = node, lost, declare_lost
        self._lock = threading.Lock()
        self._poses: dict[int, tuple[float, Point]] = {}
        self._plan: PlanId | None = None
        self._starts: dict[int, Point] = {}  # flown UAV -> its start point
        self._y_start: float | None = None
        self._start_ns: int | None = None  # the published instant, while this pass lasts
        self._offset_m = 0.0  # past the start line at that instant (a resumed pass)
        self._speed_mps, self._length_m = 0.0, 0.0
        self._ys: dict[int, deque[tuple[float, float]]] = {}  # recent (monotonic, y) per UAV
        self._behind: dict[int, tuple[float, float, str]] = {}  # uav -> (first, last, why)
        self._started: set[str] = set()  # labels of the plans this planner started
        self._awaited: AwaitedStart | None = None  # a resumed start not yet confirmed by all
        self._confirms: dict[int, tuple[float, float]] = {}  # uav -> (heard, its start)
        self._repeat: tuple[Header, float, float] | None = None  # message, next, until (wall)
        self._wait_told = time.monotonic()  # the last time the wait for a capture was said
        self._pub = node.create_publisher(Header, topics.FORMATION_START, topics.LATCHED)
        node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, self._on_diagnostics,
                                 topics.RATE_DEPTH)
        node.create_timer(CHECK_PERIOD_S, self._check)

    def watch_uav(self, k: int) -> None:
        """Subscribe vehicle k's uav{k}/mavlink/pose (the planner calls it for each UAV)."""
        self._node.create_subscription(PoseStamped, topics.mavlink_pose(k),
                                       lambda msg, k=k: self._on_pose(k, msg), topics.DEPTH)

    def on_plan(self, plan_id: PlanId, points: Sequence[Point], speed_mps: float,
                length_m: float) -> None:
        """The planner published plan `plan_id` with start points `points` (NaN: not flown),
        flown at `speed_mps` along a pass `length_m` long."""
        starts = {k: tuple(p) for k, p in enumerate(points) if all(map(math.isfinite, p))}
        y_start = next(iter(starts.values()))[1] if starts else None
        with self._lock:
            same = (self._start_ns is not None and y_start is not None
                    and abs(y_start - self._y_start) < SAME_Y_START_M)
            self._plan, self._starts, self._y_start = plan_id, starts, y_start
            self._speed_mps, self._length_m = speed_mps, length_m
            self._wait_told = time.monotonic()
            if not same:
                self._start_ns, self._repeat = None, None  # the old pass's start is void
                self._awaited = None
                self._offset_m = 0.0
                return
            start_ns, offset = self._start_ns, self._offset_m
            self._started.add(plan_id.label)
        self._publish(encode_start(start_ns, plan_id, offset), start_ns)
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
        now = time.monotonic()
        with self._lock:
            self._poses[k] = (now, (p.x, p.y, p.z))
            ys = self._ys.setdefault(k, deque())
            ys.append((now, p.y))
            while ys and ys[0][0] < now - 2.0 * SPEED_WINDOW_S:
                ys.popleft()

    def _speeds(self, now: float) -> dict[int, float]:
        """Along-track speed per UAV over about SPEED_WINDOW_S (0 without the history)."""
        out = {}
        for k, ys in self._ys.items():
            old = [(t, y) for t, y in ys if t <= now - 0.5 * SPEED_WINDOW_S]
            if old and ys[-1][0] > old[-1][0]:
                out[k] = (ys[-1][1] - old[-1][1]) / (ys[-1][0] - old[-1][0])
        return out

    def started(self, label: str) -> bool:
        """Whether this planner published a pass start for the plan labelled `label`."""
        with self._lock:
            return label in self._started

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        now = time.monotonic()
        for s in msg.status:
            k = published.bridge_status_uav(s.name)
            if k is None:
                continue
            values = {kv.key: kv.value for kv in s.values}
            instant = start_confirmations.reported_instant(values.get("pass_start"))
            with self._lock:
                if instant is None:
                    self._confirms.pop(k, None)
                else:
                    self._confirms[k] = (now, instant)
                if values.get("behind") and values.get("pass_plan") in self._started:
                    first = self._behind.get(k, (now, now, ""))[0]
                    self._behind[k] = (first, now, values["behind"])
                else:
                    self._behind.pop(k, None)

    def _check(self) -> None:
        self._send_again()
        radius = float(self._node.get_parameter("capture_radius_m").value)
        delay = float(self._node.get_parameter("start_delay_s").value)
        lost = self._lost()
        now = time.monotonic()
        with self._lock:
            if self._plan is None:
                return
            starts = {k: p for k, p in self._starts.items() if k not in lost}
            running = self._start_ns is not None
            if running:
                everyone, left_behind = self._behind_now(starts, now)
            else:
                rear = on_track(starts, self._poses, self._speeds(now), now, self._length_m)
        if running:
            self._confirm(starts)
            if everyone is not None:
                self._resume(everyone, delay, "every flown UAV holds behind its target")
            for k, why in left_behind:
                self._declare_lost(k, why)  # (the bridge's words: "... cannot keep the pass")
            return
        if rear is not None:
            self._resume(rear, max(delay, RESTARTED_DELAY_S), "the UAVs are on their tracks "
                         "past the start line (this planner started again?)")
            return
        with self._lock:
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
            self._started.add(plan_id.label)
        self._publish(encode_start(start_ns, plan_id), start_ns)
        self._node.get_logger().info(
            f"every flown UAV ({', '.join(uav_name(k) for k in sorted(starts))}) within "
            f"{radius:g} m of its start: the pass starts in {delay:g} s, wall clock "
            f"{start_ns * 1e-9:.3f} ({plan_id})")

    def _confirm(self, starts: dict[int, Point]) -> None:
        """A resumed start that some of `starts` has not confirmed by its instant: moved later,
        or waited for no longer (start_confirmations.py)."""
        with self._lock:
            awaited, plan_id, past = self._awaited, self._plan, self._offset_m
            if awaited is None or plan_id is None:
                return
            what, missing = start_confirmations.verdict(
                awaited, starts, self._confirms, time.monotonic(), time.time())
            if what == WAIT:
                return
            self._awaited = awaited.later(time.time_ns()) if what == LATER else None
            if self._awaited is not None:
                self._start_ns = start_ns = self._awaited.start_ns
        who = ", ".join(uav_name(k) for k in missing)
        if what == GIVE_UP:
            self._node.get_logger().warning(
                f"the resumed pass starts without its start confirmed by the bridge of {who}: "
                f"waited start_confirm_wait_s {awaited.wait_s:g} s ({plan_id})")
        if what != LATER:
            return
        self._publish(encode_start(start_ns, plan_id, past), start_ns)
        self._node.get_logger().warning(
            f"the resumed pass waits for the bridge of {who}, which has not confirmed its "
            f"start: it starts in {awaited.delay_s:g} s instead, from {past:.2f} m past the "
            f"start line, wall clock {start_ns * 1e-9:.3f} ({plan_id})")

    def _behind_now(self, starts: dict[int, Point], now: float
                    ) -> tuple[tuple[int, float, float] | None, list[tuple[int, str]]]:
        """(the resume point when every flown UAV with fresh poses reports `behind`, else
        None; the UAVs left behind alone for BEHIND_GRACE_S, with why). Under the lock."""
        for k in [k for k, (_, last, _) in self._behind.items() if now - last > REPORT_FRESH_S]:
            del self._behind[k]
        flying = {k: p for k, p in starts.items()
                  if k in self._poses and now - self._poses[k][0] <= POSE_FRESH_S}
        if not self._behind or not flying:
            return None, []
        if set(flying) <= set(self._behind):
            past = {k: self._poses[k][1][1] - p[1] for k, p in flying.items()}
            rear = min(past, key=past.__getitem__)
            self._behind.clear()
            return (rear, max(past[rear], 0.0), 0.0), []
        if self._awaited is not None:  # one behind may not have heard the resumed start yet
            return None, []
        left = [(k, why) for k, (first, _, why) in self._behind.items()
                if now - first > BEHIND_GRACE_S and k in starts]
        for k, _ in left:
            del self._behind[k]
        return None, left

    def _resume(self, rear: tuple[int, float, float], delay: float, why: str) -> None:
        """Publish a start from where UAV rear[0] is (rear[1] m past the start line, moving at
        rear[2] m/s): at once if it flies on, after `delay` if it holds (module doc)."""
        k, past, speed = rear
        with self._lock:
            plan_id, v = self._plan, self._speed_mps
            moving = v > 0.0 and speed > 0.5 * v
            if moving:  # an instant clearly past: the bridges join it at speed, no ramp
                start_ns = time.time_ns() - round(MOVING_BACKDATE_S * 1e9)
                past = max(0.0, past - v * MOVING_BACKDATE_S)
            else:  # from the hover: the bridges ramp their targets up from there
                start_ns = time.time_ns() + round(delay * 1e9)
            self._start_ns, self._offset_m = start_ns, past
            self._started.add(plan_id.label)
            wait = float(self._node.get_parameter("start_confirm_wait_s").value)
            # a resume again while one awaits its confirmations: the wait goes on, not anew
            since = time.monotonic() if self._awaited is None else self._awaited.since
            self._awaited = (None if moving or wait <= 0.0
                             else AwaitedStart(start_ns, delay, since, wait))
        self._publish(encode_start(start_ns, plan_id, past), start_ns)
        when = "at once (still flying)" if moving else f"in {delay:g} s"
        self._node.get_logger().warning(
            f"resuming the pass where the swarm is: {why}; from {past:.2f} m past the start "
            f"line ({uav_name(k)}, the rearmost), {when}, at {v:g} m/s, wall clock "
            f"{start_ns * 1e-9:.3f} ({plan_id})")
