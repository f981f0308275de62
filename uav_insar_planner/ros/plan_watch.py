"""What the planner sees of the swarm beyond its own plan: other planners and the plan each
agent flies.

- Other planners: every call of `statuses()` (the planner's 1 s diagnostics) reads the ROS
  graph (`get_publishers_info_by_topic` on `formation`); any publisher besides this node makes
  status "planner: formation publishers" ERROR, "second planner /planner2 publishes formation:
  plans are not applied until one remains" (the agents hold their plan meanwhile,
  ros/plan_gate.py); one log line each time the set changes. Otherwise that status is OK.
- Agents: `uav{K}/plan` (latched) says which plan agent K flies. Per-UAV status is published
  whether or not this planner has a plan of its own (a planner restarted with an infeasible
  scenario still watches the agents): for every UAV its plan flies and every agent that
  reported a plan. When an agent flies another plan than this planner's latest, the status
  is at least WARN and says which plan it flies; its position error is then against this
  planner's target for it, NaN when this planner has none.
"""
from __future__ import annotations

import math

from rclpy.node import Node
from std_msgs.msg import String

from uav_insar_planner import published
from uav_insar_planner.plan import Plan
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.plan_gate import publisher_names
from uav_insar_planner.ros.plan_msgs import PlanId

PUBLISHERS_STATUS_NAME = "planner: formation publishers"


class PlanWatch:
    """See the module docstring; `flown[k]` is agent k's last reported plan label (or None)."""

    def __init__(self, node: Node) -> None:
        self._node = node
        self._topic = node.resolve_topic_name(topics.FORMATION)
        self._me = node.get_fully_qualified_name()
        self._others: list[str] = []
        self.flown: dict[int, str | None] = {}

    def watch_uav(self, k: int) -> None:
        """Subscribe agent k's uav{k}/plan (the planner calls it for each UAV it watches)."""
        self.flown.setdefault(k, None)
        self._node.create_subscription(String, topics.flown_plan(k),
                                       lambda msg, k=k: self._on_flown(k, msg), topics.LATCHED)

    def _on_flown(self, k: int, msg: String) -> None:
        self.flown[k] = msg.data

    def other_publishers(self) -> list[str]:
        """Every publisher of `formation` but this node (one entry per publisher)."""
        names = publisher_names(self._node, self._topic)
        if self._me in names:
            names.remove(self._me)
        return names

    def statuses(self, plan: Plan | None, plan_id: PlanId | None,
                 rate_min_bps: tuple[float, ...],
                 reports: list[published.UavReport]) -> list[published.Status]:
        """The publishers status, then one status per watched UAV (see the module docstring)."""
        out = [self._publishers_status()]
        own = plan_id.label if plan_id is not None else None
        flown_by_plan = set(plan.active_uavs) if plan is not None else set()
        watched = sorted(k for k in flown_by_plan | {k for k, f in self.flown.items() if f}
                         if k < min(len(rate_min_bps), len(reports)))  # the scenario's UAVs
        for k in watched:
            target = (tuple(float(v) for v in plan.formation[k]) if k in flown_by_plan
                      else (math.nan, math.nan))
            status = published.uav_status(k, target, rate_min_bps, reports[k])
            flown = self.flown.get(k)
            status.values += [("plan_flown", flown or ""), ("plan_published", own or "")]
            if flown and flown != own:
                mine = f"this planner's is {own}" if own else "this planner has none"
                status.level = max(status.level, published.WARN)
                status.message = f"flies {flown}, not this planner's ({mine}): {status.message}"
            out.append(status)
        return out

    def _publishers_status(self) -> published.Status:
        others = self.other_publishers()
        same_name = bool(others) and set(others) == {self._me}
        if others != self._others:
            self._others = others
            if same_name:
                self._node.get_logger().warning(_second_planner_text(others, self._me))
            elif others:
                self._node.get_logger().error(_second_planner_text(others, self._me))
            else:
                self._node.get_logger().info("this planner is the only publisher of formation")
        values = [("publishers", " ".join(sorted([self._me, *others])))]
        if others:
            return published.Status(published.WARN if same_name else published.ERROR,
                                 PUBLISHERS_STATUS_NAME, _second_planner_text(others, self._me),
                                 values)
        return published.Status(published.OK, PUBLISHERS_STATUS_NAME,
                             "this planner is the only publisher of formation", values)


def _second_planner_text(others: list[str], me: str) -> str:
    if set(others) == {me}:
        return (f"another publisher of formation under this planner's name {me} (a killed "
                "predecessor, until the middleware's lease expires, or a second planner under "
                "one name): bridges and agents follow this name's newest plan")
    who = ", ".join(others)
    return (f"second planner {who} publishes formation: plans are not applied until one "
            "remains")
