"""Test helper, the FAULT-INJECTION point of the lost-and-returns test: the radio between the
ground station's ROS domain and one UAV's, as a relay between two real rclpy contexts.

Ground -> UAV: formation, formation/power (latched) and gcs/heartbeat. UAV -> ground:
uavK/pose, uavK/achieved_rate, uavK/offload, uavK/plan and the UAV bridge's own /diagnostics
status (`mavlink_bridge: uavK`). `up = False` drops everything both ways (the radio is out of
range); when it comes back the last plan is delivered again, as DDS does for a latched topic
after a link outage. On the UAV side the relay's node is named `planner`: the plan gate takes a
plan only from the planner its identity names, and this is where that planner's writer is
heard (a DDS router forwarding the planner's writer keeps its name the same way)."""
from __future__ import annotations

import threading

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray, PoseStamped
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Float64, Float64MultiArray, Header, String

from uav_insar_planner.published import bridge_status_name
from uav_insar_planner.ros import topics


class RadioRelay:
    """See the module doc. `ground_node` must be spun by the caller (e.g. the TopicWatcher's
    executor); the UAV side spins in a thread of its own."""

    def __init__(self, ground: Context, uav: Context, k: int) -> None:
        self.up = True
        self.ground_node = Node("radio", context=ground)
        self.uav_node = Node("planner", context=uav)
        self._last: dict[str, object] = {}
        self._lock = threading.Lock()
        self._status = bridge_status_name(k)
        down = [(PoseArray, topics.FORMATION, topics.LATCHED),
                (Float64MultiArray, topics.POWER, topics.LATCHED),
                (Header, topics.GCS_HEARTBEAT, topics.GCS_HEARTBEAT_QOS)]
        self._down = {name: self.uav_node.create_publisher(kind, "/" + name, qos)
                      for kind, name, qos in down}
        for kind, name, qos in down:
            self.ground_node.create_subscription(
                kind, "/" + name, lambda m, name=name: self._to_uav(name, m), qos)
        up = [(PoseStamped, topics.pose(k), topics.DEPTH),
              (Float64, topics.achieved_rate(k), topics.RATE_DEPTH),
              (Float64MultiArray, topics.offload(k), topics.RATE_DEPTH),
              (String, topics.flown_plan(k), topics.LATCHED)]
        for kind, name, qos in up:
            pub = self.ground_node.create_publisher(kind, "/" + name, qos)
            self.uav_node.create_subscription(kind, "/" + name,
                                              lambda m, pub=pub: self._to_ground(pub, m), qos)
        self._diag = self.ground_node.create_publisher(DiagnosticArray, topics.DIAGNOSTICS,
                                                       topics.DEPTH)
        self.uav_node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS,
                                          self._diagnostics, topics.RATE_DEPTH)
        self._executor = SingleThreadedExecutor(context=uav)
        self._executor.add_node(self.uav_node)
        self._thread = threading.Thread(target=self._executor.spin, daemon=True)
        self._thread.start()

    def set_up(self, up: bool) -> None:
        """Radio in range (True) or not; back in range, the latched plan arrives again."""
        with self._lock:
            self.up = up
            again = dict(self._last) if up else {}
        for name, msg in again.items():
            self._down[name].publish(msg)

    def _to_uav(self, name: str, msg: object) -> None:
        with self._lock:
            if name != topics.GCS_HEARTBEAT:
                self._last[name] = msg
            if not self.up:
                return
        self._down[name].publish(msg)

    def _to_ground(self, pub, msg: object) -> None:
        if self.up:
            pub.publish(msg)

    def _diagnostics(self, msg: DiagnosticArray) -> None:
        mine = [s for s in msg.status if s.name == self._status]
        if self.up and mine:
            self._diag.publish(DiagnosticArray(header=msg.header, status=mine))

    def destroy(self) -> None:
        self._executor.shutdown()
        self._thread.join(5.0)
        self.uav_node.destroy_node()
        self.ground_node.destroy_node()
