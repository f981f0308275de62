"""The topics page: every topic and service of the suite, from the registry
uav_insar_planner/ros/topics.py INTERFACE."""
from __future__ import annotations

import re

import reference_md as md

from uav_insar_planner.ros.topics import FRAME_ID, INTERFACE, TopicSpec
from uav_insar_planner.swarm import MAX_UAVS, MIN_UAVS


def topic_anchor(spec: TopicSpec) -> str:
    """The anchor of `spec` on the topics page (`topic-uavk-pose`, `service-replan`)."""
    slug = re.sub(r"[^a-z0-9]+", "-", spec.name.replace("{k}", "k").lower()).strip("-")
    return f"{'service' if spec.is_service else 'topic'}-{slug}"


def shown_name(spec: TopicSpec) -> str:
    """The name a user sees with every node in the root namespace: `/uav{k}/pose`, and a
    service's `~` as its server's node name."""
    name = spec.name
    if name.startswith("~/"):
        return f"/{spec.publishers[0]}/{name[2:]}"
    return name if name.startswith("/") else "/" + name


def qos_text(spec: TopicSpec) -> str:
    """Reliability, durability and history depth of the publishers' profile, and its name."""
    q = spec.profile()
    return (f"{q.reliability.name.lower()}, {q.durability.name.lower()}, depth {q.depth} "
            f"(`{spec.qos}`)")


def _nodes(names: tuple[str, ...]) -> str:
    return ", ".join(f"[`{n}`](commands.md#{md.heading_id(n)})" for n in names) or "-"


def topics_page() -> str:
    """The Markdown of reference/topics.md."""
    topics = [s for s in INTERFACE if not s.is_service]
    services = [s for s in INTERFACE if s.is_service]
    lines = ["# Topics and services", "",
             md.generated_from("uav_insar_planner/ros/topics.py"), "",
             "Every topic and service the nodes of the suite create. The names are relative "
             "but `/diagnostics`, shown here with the nodes in the root namespace: "
             "`-r __ns:=/swarm1` moves them all (give the planner and its agents the same "
             "namespace). `{k}` is a UAV, k = 0..num_uavs - 1 (the scenario parameter "
             f"`num_uavs`, {MIN_UAVS} to {MAX_UAVS}; Table I's 3: k = 0, 1, 2); `/formation` "
             "holds one pose and `/formation/power` one row per UAV; the agent of UAV k "
             "publishes only its own. A node of one UAV may also run in that UAV's namespace "
             "(`-r __ns:=/uav1`, as a stack on the UAV's computer): its topics stay the "
             "swarm's. Frame "
             f"`{FRAME_ID}`: x = range / across-track, y = azimuth / along-track, z = up; SI "
             "units on every topic.", "",
             "QoS is the publishers' profile; each subscriber asks for the same reliability and "
             "durability, and may keep a deeper history. `transient_local` topics are latched: "
             "a late subscriber gets the last message.", "", "## Topics", ""]
    lines += md.table(("Topic", "Type", "QoS", "Publishers", "Subscribers", "Content"),
                      ([f"{md.anchor(topic_anchor(s))}`{shown_name(s)}`", md.code(s.msg_type),
                        qos_text(s), _nodes(s.publishers), _nodes(s.subscribers),
                        md.text(s.description)] for s in topics))
    lines += ["", "## Services", ""]
    lines += md.table(("Service", "Type", "Server", "Content"),
                      ([f"{md.anchor(topic_anchor(s))}`{shown_name(s)}` (`{s.name}`)",
                        md.code(s.msg_type), _nodes(s.publishers), md.text(s.description)]
                       for s in services))
    lines += ["", "Besides these, rclpy gives every node `/rosout`, `/parameter_events` and its "
              "parameter and type-description services."]
    return "\n".join(lines) + "\n"
