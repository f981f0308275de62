"""The ground station's heartbeat, both ends: the planner sends it, a bridge listens.

`GcsHeartbeat(node)` (the planner): std_msgs/Header on `gcs/heartbeat` (topics.GCS_HEARTBEAT,
best effort, volatile: topics.GCS_HEARTBEAT_QOS) every param_specs.nodes.GCS_HEARTBEAT_PERIOD_S;
stamp = the node's clock (wall clock unless use_sim_time), frame_id = its fully qualified
name. The stamp is for people and logs: the bridge times the silence on its own monotonic
clock from when it received something, so the two clocks need not agree.

`GcsLink(node, on_heard, swarm_ns)` (the bridge): subscribes gcs/heartbeat and calls
`on_heard(what, True)` for each one; `heard(what)` is the same door for the other messages
from the ground (the plan, through PlanGate's `on_message`; a pass start: `on_heard(what,
False)`), so that anything the ground sends counts as proof of a live radio link, once a
heartbeat has come (mavlink/holds.py).

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

MAX_NAME = 100  # characters of the sender's name kept for the log


class GcsHeartbeat:
    """See the module doc."""

    def __init__(self, node: Node) -> None:
        self._node = node
        self._name = node.get_fully_qualified_name()
        self._pub = node.create_publisher(Header, topics.GCS_HEARTBEAT, topics.GCS_HEARTBEAT_QOS)
        node.create_timer(GCS_HEARTBEAT_PERIOD_S, self.beat)

    def beat(self) -> None:
        self._pub.publish(Header(stamp=self._node.get_clock().now().to_msg(),
                                 frame_id=self._name))


class GcsLink:
    """See the module doc."""

    def __init__(self, node: Node, on_heard: Callable[[str, bool], None], swarm_ns: str
                 ) -> None:
        self._on_heard = on_heard
        node.create_subscription(Header, topics.resolve(swarm_ns, topics.GCS_HEARTBEAT),
                                 self._on_heartbeat, topics.GCS_HEARTBEAT_QOS)

    def heard(self, what: str) -> None:
        """Something came from the ground station (`what` names it for the log)."""
        self._on_heard(what, False)

    def _on_heartbeat(self, msg: Header) -> None:
        name = msg.frame_id[:MAX_NAME] or "an unnamed sender"  # a name, not a payload
        self._on_heard(f"gcs/heartbeat from {name}", True)
