"""The registry of the suite's ROS interface (ros/topics.py INTERFACE, which the documentation's
topics page shows) is what the nodes create: the real `planner`, an `agent` and the all-in-one
`mavlink_bridge` run as processes on a private domain, and the graph, seen from the test's
node, holds exactly the registry's topics and services of each, with its types and QoS."""
from __future__ import annotations

import signal
import subprocess

import process_group
import pytest

from uav_insar_planner.param_specs.nodes import NODE_SPECS
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.topics import INTERFACE, QOS_PROFILES, TopicSpec
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, uavs

# Table I's swarm: this test is of three UAVs (test_num_uavs.py flies others)
UAVS = uavs(DEFAULT_NUM_UAVS)

pytestmark = pytest.mark.timeout(120)
AGENT_UAV = 0
# The UAVs whose topics each node creates: the agent flies one, the all-in-one bridge all.
NODE_UAVS = {"planner": tuple(UAVS), "agent": (AGENT_UAV,), "mavlink_bridge": tuple(UAVS)}
RCLPY_TOPICS = ("/rosout", "/parameter_events")
RCLPY_SERVICE_PACKAGES = ("rcl_interfaces/srv/", "type_description_interfaces/srv/")
UP_TIMEOUT_S = 40.0


def absolute(name: str, node: str) -> str:
    """`name` as created by node `node` in the root namespace."""
    if name.startswith("~/"):
        return f"/{node}/{name[2:]}"
    return topics.resolve("/", name)


def expected(node: str, role: str, services: bool = False) -> dict[str, TopicSpec]:
    """Absolute name -> spec of what the registry says `node` creates in `role`
    ("publishers" or "subscribers"; for services, "publishers" are the servers)."""
    return {absolute(name, node): spec for spec in INTERFACE
            if spec.is_service == services and node in getattr(spec, role)
            for name in spec.names(NODE_UAVS[node])}


def test_per_uav_templates_are_the_names_the_code_uses():
    registry = {spec.name for spec in INTERFACE}
    for name_of in (topics.pose, topics.achieved_rate, topics.offload, topics.flown_plan,
                    topics.mavlink_pose, topics.mavlink_claim):
        matches = [s for s in INTERFACE if s.per_uav
                   and all(s.name.format(k=k) == name_of(k) for k in UAVS)]
        assert len(matches) == 1, name_of.__name__
    for name in (topics.FORMATION, topics.POWER, topics.FORMATION_START, topics.MARKERS,
                 topics.FLOWN_MARKERS, topics.DIAGNOSTICS, topics.GCS_HEARTBEAT, topics.REPLAN):
        assert name in registry, name
    assert len(registry) == len(INTERFACE), "one entry per name"


def test_every_entry_is_well_formed():
    for spec in INTERFACE:
        assert spec.msg_type.count("/") == 2 and spec.msg_type.split("/")[1] in ("msg", "srv")
        assert (spec.qos == "") == spec.is_service, spec.name
        assert spec.is_service or spec.qos in QOS_PROFILES, spec.name
        assert set(spec.publishers + spec.subscribers) <= set(NODE_SPECS), spec.name
        assert spec.publishers and spec.description, spec.name


def _by_node(graph_call, node: str, drop) -> dict[str, list[str]]:
    try:
        return {name: types for name, types in graph_call(node, "/") if not drop(name, types)}
    except Exception:  # noqa: BLE001 - rclpy raises NodeNameNonExistentError until discovered
        return {}


def _seen(w, node: str) -> dict[str, dict[str, list[str]]]:
    n = w.node

    def rclpy_topic(name, types):
        return name in RCLPY_TOPICS

    def rclpy_service(name, types):
        return all(t.startswith(RCLPY_SERVICE_PACKAGES) for t in types)

    return {"publishers": _by_node(n.get_publisher_names_and_types_by_node, node, rclpy_topic),
            "subscribers": _by_node(n.get_subscriber_names_and_types_by_node, node,
                                    rclpy_topic),
            "services": _by_node(n.get_service_names_and_types_by_node, node, rclpy_service)}


def _wanted(node: str) -> dict[str, dict[str, list[str]]]:
    return {"publishers": {t: [s.msg_type] for t, s in expected(node, "publishers").items()},
            "subscribers": {t: [s.msg_type] for t, s in expected(node, "subscribers").items()},
            "services": {t: [s.msg_type] for t, s in
                         expected(node, "publishers", services=True).items()}}


def _qos_problems(w, node: str) -> list[str]:
    """Each endpoint of `node` whose reliability or durability is not the registry's."""
    problems = []
    for role, infos_of in (("publishers", w.node.get_publishers_info_by_topic),
                           ("subscribers", w.node.get_subscriptions_info_by_topic)):
        for topic, spec in expected(node, role).items():
            want = spec.profile()
            mine = [i for i in infos_of(topic) if i.node_name == node]
            if not mine:
                problems.append(f"{node}: no {role[:-1]} info on {topic}")
            for info in mine:
                got = info.qos_profile
                if (got.reliability, got.durability) != (want.reliability, want.durability):
                    problems.append(f"{node} {role[:-1]} {topic}: {got.reliability.name}, "
                                    f"{got.durability.name}; registry {spec.qos}: "
                                    f"{want.reliability.name}, {want.durability.name}")
    return problems


def _differences(w) -> list[str]:
    """What each node creates that the registry does not say, and the reverse (none: equal)."""
    lines = []
    for node in NODE_UAVS:
        seen, wanted = _seen(w, node), _wanted(node)
        for role in wanted:
            for name in sorted(set(seen[role]) | set(wanted[role])):
                got, want = seen[role].get(name), wanted[role].get(name)
                if got != want:
                    lines.append(f"{node} {role} {name}: graph {got}, registry {want}")
    return lines


def _stop(procs: list[subprocess.Popen], timeout: float = 10.0) -> None:
    """Ctrl-C to each node's process group (each has a session of its own), then SIGKILL."""
    for proc in procs:
        if proc.poll() is None:
            process_group.kill_group(proc, signal.SIGINT)
    for proc in procs:
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            pass
        process_group.kill_group(proc)


def test_the_running_nodes_create_exactly_the_registry(watcher, procs):
    # udpin on port 0: the bridge only listens, on ports the kernel picks, so it sends
    # nothing to any vehicle another test runs and takes no port one may want.
    connections = ", ".join("'udpin:127.0.0.1:0'" for _ in UAVS)
    started = [
        procs("planner", "-p", "num_slots:=8"),
        # position_source autopilot and pass_start planner: the subscriptions they add exist.
        procs("agent", "-p", "num_slots:=8", "-p", f"uav_id:={AGENT_UAV}",
              "-p", "position_source:=autopilot"),
        procs("mavlink_bridge", "-p", f"connections:=[{connections}]",
              "-p", "pass_start:=planner"),
    ]
    w = watcher
    try:
        w.spin_until(lambda: not _differences(w), UP_TIMEOUT_S, procs=started)
        for proc in started:
            assert proc.poll() is None, proc.communicate(timeout=10)[0][-2000:]
        assert not _differences(w), _differences(w)
        problems = [p for node in NODE_UAVS for p in _qos_problems(w, node)]
        assert not problems, problems
        registry = {absolute(name, "planner"): spec.msg_type for spec in INTERFACE
                    if not spec.is_service for name in spec.names(UAVS)}
        on_graph = {t: types for t, types in w.node.get_topic_names_and_types()
                    if t not in RCLPY_TOPICS}
        assert {t: [registry.get(t)] for t in on_graph} == on_graph
    finally:
        _stop(started)
