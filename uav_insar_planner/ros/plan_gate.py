"""One plan at a time for a consumer of `formation` + `formation/power` (the agents and the
MAVLink bridge).

`PlanGate(node, on_plan, prefix, flown_topic)` subscribes both latched topics, decodes and
validates each message (plan_msgs; a bad one is dropped, logged rate-limited and counted,
nothing changes), pairs a formation with the power message of the same stamp, and calls
`on_plan(formation, power)` only for a complete pair whose named planner is, at that moment,
the sole publisher of both topics in the ROS graph:
- a formation without its power (or the reverse) waits; a pair never mixes two plans;
- while more than one node publishes `formation` (two planners on one domain), nothing new is
  applied and the plan in use stays; when one remains, its latest complete plan is adopted
  (the latched messages of both planners are kept, per planner, for that moment);
- the latched-message race: data can arrive before the graph shows (or names) its publisher,
  so a plan is adopted only on a graph check that names its planner as the sole publisher,
  done on arrival and again every GRAPH_PERIOD_S; and a planner that leaves the graph has
  its plans forgotten, so one restarted under the same name is followed only with its own.
- several publishers under ONE name: a planner SIGKILLed and started again, whose dead
  participant stays in the graph until the middleware's lease expires (20 s in Fast DDS,
  measured across hosts): that name's newest plan is followed (its stamps increase), with a
  warning. Limit: two live planners under one name cannot be told apart; each of them warns
  of the other (ros/plan_watch.py).
With `flown_topic` (an agent's `uav{K}/plan`), the plan in use is published there
(std_msgs/String, latched) as its identity label, for the planner to report which plan each
agent flies. `prefix` starts every log line (e.g. "uav1: "). The topics are those of
`swarm_ns` (topics.swarm_namespace; default the node's namespace). `on_message(what, stamp)`,
when given, hears of every valid message and its plan's stamp (the bridge's ground-station
link, ros/gcs_link.py).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

from geometry_msgs.msg import PoseArray
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray, String

from uav_insar_planner.mavlink.guard import DropLog
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.plan_msgs import (
    DROP_LOG_PERIOD_S,
    Formation,
    PlanId,
    PlanMessageError,
    PowerSchedule,
    decode_formation,
    decode_power,
)

GRAPH_PERIOD_S = 0.5
KEPT = 8  # formations / power schedules kept while waiting for their other half


class PlanPairing:
    """The gate's decisions, without ROS: feed decoded messages, ask `choose(publishers)`."""

    def __init__(self) -> None:
        self._formations: dict[tuple[int, int], Formation] = {}
        self._powers: dict[tuple[int, int], PowerSchedule] = {}
        self.latest: dict[str, tuple[Formation, PowerSchedule]] = {}  # per planner
        self.current: PlanId | None = None
        self.mismatch: str | None = None  # the last pair refused, why (for one log line)
        self._in_graph: set[str] = set()  # publishers at the last choose()

    def add_formation(self, f: Formation) -> None:
        _keep(self._formations, f.stamp, f)
        self._pair(f.stamp)

    def add_power(self, p: PowerSchedule) -> None:
        _keep(self._powers, p.plan_id.stamp, p)
        self._pair(p.plan_id.stamp)

    def _pair(self, stamp: tuple[int, int]) -> None:
        f, p = self._formations.get(stamp), self._powers.get(stamp)
        if f is None or p is None:
            return
        if len(f.points) != p.p_com_w.shape[0]:
            self.mismatch = (f"{p.plan_id}: formation has {len(f.points)} poses, power "
                             f"{p.p_com_w.shape[0]} rows; ignored")
            return
        held = self.latest.get(p.plan_id.planner)
        if held is None or held[1].plan_id.stamp < stamp:  # stamps increase per planner
            self.latest[p.plan_id.planner] = (f, p)

    def choose(self, formation_pubs: Sequence[str],
               power_pubs: Sequence[str]) -> tuple[Formation, PowerSchedule] | None:
        """The pair to apply now, or None: only the latest plan of the sole publisher of both
        topics, and only when it is not the plan in use.

        The plans of a planner that was in the graph and has left it are forgotten first: one
        restarted under the same name must not have its predecessor's plan adopted in its
        name before its own latched plan has arrived. A planner not yet seen in the graph
        keeps its plans (its data can arrive first)."""
        present = set(formation_pubs) | set(power_pubs)
        for gone in self._in_graph - present:
            self.latest.pop(gone, None)
            for stamp in [s for s, p in self._powers.items() if p.plan_id.planner == gone]:
                del self._powers[stamp]
        self._in_graph = present
        names = set(formation_pubs)
        if len(names) != 1 or set(power_pubs) != names:
            return None
        pair = self.latest.get(next(iter(names)))
        if pair is None or pair[1].plan_id == self.current:
            return None
        self.current = pair[1].plan_id
        return pair


def _keep(store: dict, key: tuple[int, int], value: object) -> None:
    store[key] = value
    while len(store) > KEPT:
        del store[min(store)]


def publisher_names(node: Node, topic: str) -> list[str]:
    """Fully qualified names of the nodes publishing `topic` (one entry per publisher)."""
    return sorted((i.node_namespace.rstrip("/") + "/" + i.node_name)
                  for i in node.get_publishers_info_by_topic(topic))


class PlanGate:
    """See the module docstring. `dropped` counts the messages refused by validation."""

    def __init__(self, node: Node, on_plan: Callable[[Formation, PowerSchedule], None],
                 prefix: str = "", flown_topic: str | None = None,
                 swarm_ns: str | None = None,
                 on_message: Callable[[str, tuple[int, int]], None] | None = None) -> None:
        self._node, self._on_plan, self._prefix = node, on_plan, prefix
        self._on_message = on_message
        self._pairing = PlanPairing()
        self._drops = DropLog(DROP_LOG_PERIOD_S)
        self._held: tuple[str, ...] = ()
        ns = node.get_namespace() if swarm_ns is None else swarm_ns
        self._formation_topic = node.resolve_topic_name(topics.resolve(ns, topics.FORMATION))
        self._power_topic = node.resolve_topic_name(topics.resolve(ns, topics.POWER))
        self._flown_pub = (node.create_publisher(String, topics.resolve(ns, flown_topic),
                                                 topics.LATCHED) if flown_topic else None)
        node.create_subscription(PoseArray, self._formation_topic, self._on_formation,
                                 topics.LATCHED)
        node.create_subscription(Float64MultiArray, self._power_topic, self._on_power,
                                 topics.LATCHED)
        node.create_timer(GRAPH_PERIOD_S, self._check)

    @property
    def dropped(self) -> int:
        return self._drops.total

    @property
    def current(self) -> PlanId | None:
        return self._pairing.current

    def _drop(self, error: PlanMessageError) -> None:
        line = self._drops.drop("plan message", str(error))
        if line is not None:
            self._node.get_logger().warning(self._prefix + line)

    def _on_formation(self, msg: PoseArray) -> None:
        try:
            formation = decode_formation(msg)
        except PlanMessageError as exc:
            self._drop(exc)
            return
        self._heard("formation", formation.stamp)
        self._pairing.add_formation(formation)
        self._check()

    def _on_power(self, msg: Float64MultiArray) -> None:
        try:
            power = decode_power(msg)
        except PlanMessageError as exc:
            self._drop(exc)
            return
        self._heard("formation/power", power.plan_id.stamp)
        self._pairing.add_power(power)
        self._check()

    def _heard(self, topic: str, stamp: tuple[int, int]) -> None:
        if self._on_message is not None:
            self._on_message(f"{topic} {stamp[0]}.{stamp[1]:09d}", stamp)

    def _check(self) -> None:
        log = self._node.get_logger()
        if self._pairing.mismatch:
            log.error(self._prefix + self._pairing.mismatch)
            self._pairing.mismatch = None
        formation_pubs = publisher_names(self._node, self._formation_topic)
        power_pubs = publisher_names(self._node, self._power_topic)
        held = tuple(formation_pubs) if len(formation_pubs) > 1 else ()
        if held != self._held:
            self._held = held
            if held and len(set(held)) == 1:
                log.warning(f"{self._prefix}{len(held)} publishers of formation under one "
                            f"name, {held[0]}: a planner started again while its killed "
                            "predecessor is still in the graph (until the middleware's lease "
                            "expires); following that name's newest plan")
            elif held:
                log.error(f"{self._prefix}{len(held)} publishers of formation "
                          f"({', '.join(held)}): keeping {self.current or 'no plan'}, "
                          "nothing new is applied until one remains")
            else:
                log.info(f"{self._prefix}one publisher of formation again: "
                         f"{', '.join(formation_pubs) or 'none'}")
        chosen = self._pairing.choose(formation_pubs, power_pubs)
        if chosen is not None:
            self._on_plan(*chosen)
            if self._flown_pub is not None:
                self._flown_pub.publish(String(data=chosen[1].plan_id.label))
