"""The ground station's heartbeat, both ends: the planner sends it, a bridge listens.

`GcsHeartbeat(node, current_plan)` (the planner): std_msgs/Header on `gcs/heartbeat`
(topics.GCS_HEARTBEAT, best effort, volatile: topics.GCS_HEARTBEAT_QOS) every
param_specs.nodes.GCS_HEARTBEAT_PERIOD_S; stamp = the node's clock (wall clock unless
use_sim_time), frame_id = the label of the plan it last published (`plan /planner
1796439450.623225672`, plan_msgs.PlanId.label), or its fully qualified name before its first
plan. The stamp is for people and logs: the bridge times the silence on its own monotonic
clock from when it received something, so the two clocks need not agree.

`GcsLink(node, on_heard, swarm_ns, flown)` (the bridge): subscribes gcs/heartbeat and calls
`on_heard(what, True, newer)` for each one; `heard(what, stamp)` is the same door for the
other messages from the ground (the plan, through PlanGate's `on_message`; a pass start:
`on_heard(what, False, newer)`), so that anything the ground sends counts as proof of a live
radio link, once a heartbeat has come (mavlink/holds.py). `newer`: the message is of, or the
heartbeat names, a plan other than the one flown (`flown()`, the PlanGate's current): after a
silence the held vehicles then wait for that plan (the planner may have re-planned without
one of them) rather than rejoin the old one.

Sized for the documented loss: at GCS_HEARTBEAT_PERIOD_S the shortest gcs_timeout_s
(GCS_TIMEOUT_MIN_S) spans ten heartbeats, all lost with probability 0.3^10 = 6e-6 at 30 %
loss, so a hold means the ground is gone, not that a heartbeat was.
"""
from __future__ import annotations

from collections.abc import Callable

from rclpy.node import Node
from std_msgs.msg import Header

from uav_insar_planner.param_specs.nodes import GCS_HEARTBEAT_PERIOD_S
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.plan_msgs import PlanId

MAX_NAME = 100  # characters of the sender's name kept for the log


class GcsHeartbeat:
    """See the module doc."""

    def __init__(self, node: Node, current_plan: Callable[[], PlanId | None]) -> None:
        self._node, self._current_plan = node, current_plan
        self._name = node.get_fully_qualified_name()
        self._pub = node.create_publisher(Header, topics.GCS_HEARTBEAT, topics.GCS_HEARTBEAT_QOS)
        node.create_timer(GCS_HEARTBEAT_PERIOD_S, self.beat)

    def beat(self) -> None:
        plan = self._current_plan()
        self._pub.publish(Header(stamp=self._node.get_clock().now().to_msg(),
                                 frame_id=self._name if plan is None else plan.label))


class GcsLink:
    """See the module doc."""

    def __init__(self, node: Node, on_heard: Callable[[str, bool, bool], None], swarm_ns: str,
                 flown: Callable[[], PlanId | None]) -> None:
        self._on_heard, self._flown = on_heard, flown
        node.create_subscription(Header, topics.resolve(swarm_ns, topics.GCS_HEARTBEAT),
                                 self._on_heartbeat, topics.GCS_HEARTBEAT_QOS)

    def heard(self, what: str, stamp: tuple[int, int]) -> None:
        """A message of plan `stamp` came from the ground station (`what` names it for the
        log)."""
        self._on_heard(what, False, self._newer(stamp))

    def _newer(self, stamp: tuple[int, int]) -> bool:
        flown = self._flown()
        return flown is None or flown.stamp != stamp

    def _on_heartbeat(self, msg: Header) -> None:
        plan = PlanId.from_label(msg.frame_id)  # None: a planner without a plan, or another
        name = (msg.frame_id if plan is None else plan.planner)[:MAX_NAME] or "an unnamed sender"
        what = f"gcs/heartbeat from {name}" + ("" if plan is None else
                                                f" ({plan.sec}.{plan.nanosec:09d})")
        self._on_heard(what, True, plan is not None and self._newer(plan.stamp))
