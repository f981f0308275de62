"""A node that records what the suite publishes: for `make demo` and the tests.

    watcher = TopicWatcher(context)   # its own node and executor in `context` (None: a
    watcher.spin_until(lambda: watcher.formations, 30.0)   # context of its own, on
    watcher.destroy()                                      # ROS_DOMAIN_ID)

It subscribes with each topic's own QoS (ros/topics.py) and keeps every message in arrival
order: `formations`, `powers`, `diagnostics`, and per UAV k `rates[k]` (bit/s), `offloads[k]`
(the agent's [slot, power_w, energy_used_j, energy_left_j]), `poses[k]`, `mavlink_poses[k]`
and `flown_plans[k]` (the identity label of each plan agent k adopted; `plan_ids()` decodes
the plans seen on formation/power). An optional `on_mavlink_pose(k, msg)` sees each vehicle
position as it arrives.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseArray, PoseStamped
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Float64, Float64MultiArray, String

from uav_insar_planner.published import PLAN_STATUS_NAME
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.plan_msgs import PlanMessageError, decode_formation, decode_power
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, uavs

SPIN_STEP_S = 0.05


class TopicWatcher:
    """See the module docstring. `node` is the rclpy node, for extra subscriptions or clients."""

    def __init__(self, context: Context | None = None, name: str = "watcher",
                 on_mavlink_pose: Callable[[int, Any], None] | None = None,
                 num_uavs: int = DEFAULT_NUM_UAVS) -> None:
        self._own_context = context is None
        if context is None:
            context = Context()
            rclpy.init(args=[name], context=context)
        self.node = Node(name, context=context)
        self.uavs = uavs(num_uavs)  # the per-UAV topics watched: uav0..uav(num_uavs-1)
        self.formations: list[Any] = []
        self.powers: list[Any] = []
        self.diagnostics: list[Any] = []
        self.rates: dict[int, list[float]] = {k: [] for k in self.uavs}
        self.poses: dict[int, list[Any]] = {k: [] for k in self.uavs}
        self.mavlink_poses: dict[int, list[Any]] = {k: [] for k in self.uavs}
        self.offloads: dict[int, list[list[float]]] = {k: [] for k in self.uavs}
        self.flown_plans: dict[int, list[str]] = {k: [] for k in self.uavs}
        self._on_mavlink_pose = on_mavlink_pose
        n = self.node
        n.create_subscription(PoseArray, "/" + topics.FORMATION, self.formations.append,
                              topics.LATCHED)
        n.create_subscription(Float64MultiArray, "/" + topics.POWER, self.powers.append,
                              topics.LATCHED)
        n.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, self.diagnostics.append,
                              topics.RATE_DEPTH)
        for k in self.uavs:
            n.create_subscription(Float64, "/" + topics.achieved_rate(k),
                                  lambda m, k=k: self.rates[k].append(m.data),
                                  topics.RATE_DEPTH)
            n.create_subscription(PoseStamped, "/" + topics.pose(k), self.poses[k].append,
                                  topics.DEPTH)
            n.create_subscription(Float64MultiArray, "/" + topics.offload(k),
                                  lambda m, k=k: self.offloads[k].append(list(m.data)),
                                  topics.RATE_DEPTH)
            n.create_subscription(PoseStamped, "/" + topics.mavlink_pose(k),
                                  lambda m, k=k: self._mavlink_pose(k, m), topics.RATE_DEPTH)
            n.create_subscription(String, "/" + topics.flown_plan(k),
                                  lambda m, k=k: self.flown_plans[k].append(m.data),
                                  topics.LATCHED)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(n)

    def _mavlink_pose(self, k: int, msg: Any) -> None:
        self.mavlink_poses[k].append(msg)
        if self._on_mavlink_pose is not None:
            self._on_mavlink_pose(k, msg)

    def add_node(self, node: Node) -> None:
        """Spin `node` (e.g. an in-process planner) on the watcher's executor too."""
        self.executor.add_node(node)

    def spin_until(self, done: Callable[[], Any], timeout: float,
                   procs: Sequence[Any] = ()) -> bool:
        """Spin until done() is truthy or `timeout` s passed; False at once when one of
        `procs` (Popen) has exited."""
        end = time.monotonic() + timeout
        while not done():
            if time.monotonic() > end or any(p.poll() is not None for p in procs):
                return False
            self.executor.spin_once(timeout_sec=SPIN_STEP_S)
        return True

    def call(self, srv_type: Any, name: str, request: Any, timeout: float = 10.0,
             resend_s: float = 2.0) -> Any:
        """The answer of service `name`, or None after `timeout` s; for idempotent services
        only (parameters), because the request is sent again every `resend_s` s: a client
        that has just seen the service ready can still miss its answer while the server has
        not yet discovered the client's response reader (a DDS discovery race)."""
        client = self.node.create_client(srv_type, name)
        try:
            end = time.monotonic() + timeout
            if not self.spin_until(client.service_is_ready, timeout):
                return None
            while time.monotonic() < end:
                future = client.call_async(request)
                if self.spin_until(future.done, min(resend_s, end - time.monotonic())):
                    return future.result()
                client.remove_pending_request(future)
            return None
        finally:
            self.node.destroy_client(client)

    def agents_matched(self) -> bool:
        """True once every agent's achieved_rate publisher has been discovered: a new process
        can take a discovery announcement period (~3 s) to be seen, and rates sent before
        that are lost (volatile), so wait for this before a plan starts their slots."""
        return all(self.node.count_publishers("/" + topics.achieved_rate(k)) for k in self.uavs)

    def plan_ids(self) -> tuple[list[Any], list[Any]]:
        """(formation stamps (sec, nanosec), power PlanIds) in arrival order; an entry that
        fails validation (ros/plan_msgs.py) is its error text instead."""
        return ([_decoded(decode_formation, m, "stamp") for m in self.formations],
                [_decoded(decode_power, m, "plan_id") for m in self.powers])

    def plan_status(self) -> Any | None:
        """The planner's latest plan status (the bridge publishes on /diagnostics too)."""
        found = [s for msg in self.diagnostics for s in msg.status
                 if s.name == PLAN_STATUS_NAME]
        return found[-1] if found else None

    def plan_failed(self) -> bool:
        """True once the plan status is ERROR (infeasible, or the solve failed)."""
        status = self.plan_status()
        return status is not None and status.level == DiagnosticStatus.ERROR

    def statuses(self, index: int = -1) -> dict[str, Any]:
        """The DiagnosticStatus entries of diagnostics[index], by name."""
        return {s.name: s for s in self.diagnostics[index].status}

    def destroy(self) -> None:
        """Destroy the node (and the context, when the watcher made it)."""
        self.executor.shutdown()
        context = self.node.context
        self.node.destroy_node()
        if self._own_context:
            context.try_shutdown()


def _decoded(decode: Callable[[Any], Any], msg: Any, field: str) -> Any:
    try:
        return getattr(decode(msg), field)
    except PlanMessageError as exc:
        return str(exc)
