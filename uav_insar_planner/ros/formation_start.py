"""The planner's one start of the pass for the whole formation (`formation/start`), for
bridges that each fly one UAV (their side: mavlink/start_gate.py's `planner_start`).

No per-UAV bridge sees the other vehicles, so none can tell when the formation is complete.
The planner can: it watches uav{K}/mavlink/pose of every UAV the current plan flies and the
swarm watch has not declared lost, and once each is fresh (younger than POSE_FRESH_S) and
within `capture_radius_m` (planner parameter, as the bridge's) of its start point
(x_k, y_start, z_k), it publishes ONE start, latched (ros/start_msgs.py): wall clock now +
`start_delay_s`, labelled with the plan's identity. Every bridge with pass_start "planner"
starts its pass at that instant; the hosts' clocks must agree (GNSS time, chrony), as an
offset dt puts a UAV v_y dt along track.

A swarm never waits for ever: `capture_timeout_s` (planner parameter, 0: no deadline) after a
bridge was first seen flying the plan, the UAVs not captured yet are declared lost
(`declare_lost`), one line naming each and why (how far from its entry, or silent); the swarm
watch re-plans without them, and the re-plan's start is captured as any other.

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

The decisions are the pure step function of ros/start_states.py (its states and transitions);
FormationStart is its node: it keeps the state under one lock, feeds the step function from
its subscriptions and its CHECK_PERIOD_S timer, and publishes, logs, declares lost and
repeats as the step function says.
"""
from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from std_msgs.msg import Header

from uav_insar_planner import published
from uav_insar_planner.plan import Vec3
from uav_insar_planner.ros import start_confirmations, topics
from uav_insar_planner.ros.plan_msgs import PlanId
from uav_insar_planner.ros.start_msgs import encode_start
from uav_insar_planner.ros.start_states import (
    Action,
    BridgeReport,
    DeclareLost,
    Log,
    NewPlan,
    Now,
    Observed,
    Publish,
    StartState,
    step,
)
from uav_insar_planner.track.leg import SurveyLeg
from uav_insar_planner.track.pass_clock import PassClock

CHECK_PERIOD_S = 0.1
REPEAT_PERIOD_S = 0.5
REPEAT_AFTER_S = 1.0
REPEAT_MIN_S = 3.0
SPEED_WINDOW_S = 1.0  # along-track speed from the poses of the last second


class FormationStart:
    """See the module docstring. `lost()` is the set of UAVs the swarm watch declared lost;
    `node` has the parameters capture_radius_m, start_delay_s, start_confirm_wait_s and
    capture_timeout_s."""

    def __init__(self, node: Node, lost: Callable[[], set[int]],
                 declare_lost: Callable[[int, str], None]) -> None:
        self._node, self._lost, self._declare_lost = node, lost, declare_lost
        self._lock = threading.Lock()  # over everything below
        self._state = StartState()
        self._poses: dict[int, tuple[float, Vec3]] = {}
        self._ys: dict[int, deque[tuple[float, float]]] = {}  # recent (monotonic, y) per UAV
        self._reports: list[BridgeReport] = []  # heard since the last check
        self._repeat: tuple[Header, float, float] | None = None  # message, next, until (wall)
        self._pub = node.create_publisher(Header, topics.FORMATION_START, topics.LATCHED)
        node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, self._on_diagnostics,
                                 topics.RATE_DEPTH)
        node.create_timer(CHECK_PERIOD_S, self._check)

    def watch_uav(self, k: int) -> None:
        """Subscribe vehicle k's uav{k}/mavlink/pose (the planner calls it for each UAV)."""
        self._node.create_subscription(PoseStamped, topics.mavlink_pose(k),
                                       lambda msg, k=k: self._on_pose(k, msg), topics.DEPTH)

    def on_plan(self, plan_id: PlanId, points: Sequence[Vec3], speed_mps: float,
                length_m: float, leg: SurveyLeg | None = None) -> None:
        """The planner published plan `plan_id` with start points `points` (NaN: not flown),
        flown at `speed_mps` along a pass `length_m` long, on survey strip `leg`."""
        self._step(NewPlan(plan_id, tuple(points), speed_mps, length_m, leg))

    def clock(self, leg: SurveyLeg | None = None) -> PassClock | None:
        """The start published for the pass flown on `leg` (wall clock), None while there is
        none (or the pass flown is another strip's)."""
        with self._lock:
            return self._state.clock if self._state.leg == leg else None

    def started(self, label: str) -> bool:
        """Whether this planner published a pass start for the plan labelled `label`."""
        with self._lock:
            return label in self._state.started

    def _step(self, event: NewPlan | None) -> None:
        """One step of the state (`event`, or a check with what was heard), then its actions."""
        lost = frozenset(self._lost()) if event is None else frozenset()
        param = self._node.get_parameter
        now = Now(time.monotonic(), time.time())
        with self._lock:
            if event is None:
                starts = self._state.starts
                event = Observed(
                    dict(self._poses), self._speeds(now.mono), tuple(self._reports), lost,
                    float(param("capture_radius_m").value), float(param("start_delay_s").value),
                    float(param("start_confirm_wait_s").value), self._bridged(starts),
                    float(param("capture_timeout_s").value))
                self._reports.clear()
            self._state, actions = step(self._state, event, now)
            if self._state.clock is None:
                self._repeat = None  # the old pass's start is void
        self._execute(actions)

    def _execute(self, actions: Sequence[Action]) -> None:
        log = self._node.get_logger()
        for action in actions:
            if isinstance(action, Publish):
                self._publish(encode_start(action.clock, action.plan), action.clock.start_s)
            elif isinstance(action, Log) and action.level == "warning":
                log.warning(action.text)  # (rclpy: one severity per call site)
            elif isinstance(action, Log):
                log.info(action.text)
            elif isinstance(action, DeclareLost):
                self._declare_lost(action.k, f"{action.by}: {action.why}")

    def _publish(self, msg: Header, start_s: float) -> None:
        """Send a start now, and again every REPEAT_PERIOD_S (module doc)."""
        self._pub.publish(msg)
        now = time.time()
        until = max(start_s + REPEAT_AFTER_S, now + REPEAT_MIN_S)
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

    def _bridged(self, starts: Mapping[int, Vec3]) -> bool:
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

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        now = time.monotonic()
        for s in msg.status:
            k = published.bridge_status_uav(s.name)
            if k is None:
                continue
            values = {kv.key: kv.value for kv in s.values}
            report = BridgeReport(k, now,
                                  start_confirmations.reported_number(values.get("pass_start")),
                                  values.get("behind", ""), values.get("pass_plan", ""),
                                  start_confirmations.reported_number(values.get("speed_mps")))
            with self._lock:
                self._reports.append(report)

    def _check(self) -> None:
        self._send_again()
        self._step(None)
