"""The topics page: every topic and service of the suite, from the registry
uav_insar_planner/ros/topics.py INTERFACE."""
from __future__ import annotations

import re

import reference_md as md

from uav_insar_planner.ros.topics import FRAME_ID, INTERFACE, TopicSpec
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, MAX_UAVS, MIN_UAVS, uavs


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
    """Reliability, durability and history depth of the publishers' profile, and its name;
    the subscribers' too where it differs."""
    text = _profile_text(spec.profile(), spec.qos)
    if spec.reader_qos:
        text += "; read as " + _profile_text(spec.reader_profile(), spec.reader_qos)
    return text


def _profile_text(q, name: str) -> str:
    return (f"{q.reliability.name.lower()}, {q.durability.name.lower()}, depth {q.depth} "
            f"(`{name}`)")


def _nodes(names: tuple[str, ...]) -> str:
    return ", ".join(f"[`{n}`](commands.md#{md.heading_id(n)})" for n in names) or "-"


def recorded_names(num_uavs: int = DEFAULT_NUM_UAVS) -> list[str]:
    """Every topic of the registry as a bag of a swarm of `num_uavs` names it (a recorder
    takes every topic that has a publisher), in the registry's order."""
    return ["/" + name.lstrip("/") for spec in INTERFACE if not spec.is_service
            for name in spec.names(uavs(num_uavs))]


def recorded_topics() -> str:
    """The list of a demo bag's topics on recording.md (its `<!-- generated: recorded topics
    -->` line), from the registry."""
    topics = [s for s in INTERFACE if not s.is_service]
    shared = sum(not s.per_uav for s in topics)
    per_uav = sum(s.per_uav for s in topics)
    bridge_only = [s for s in topics if s.publishers == ("mavlink_bridge",)]
    lines = [f"A `make demo` bag (Table I's {DEFAULT_NUM_UAVS} UAVs, flown by the MAVLink "
             f"bridge) holds these {len(recorded_names())} topics, every topic of the "
             "[topic reference](reference/topics.md) (generated, as this list, from "
             f"`ros/topics.py`); a swarm of num_uavs UAVs has {shared} + {per_uav} x num_uavs. "
             "Without the bridge (`--no-mavlink`) the topics only it publishes ("
             + ", ".join(md.code(shown_name(s)) for s in bridge_only) + ") are missing.", ""]
    lines += md.table(("Topic", "Type", "Publishers"), (
        [", ".join(f"[`{name}`](reference/topics.md#{topic_anchor(s)})"
                   for name in ("/" + n.lstrip("/") for n in s.names(uavs(DEFAULT_NUM_UAVS)))),
         md.code(s.msg_type), ", ".join(md.code(n) for n in s.publishers)] for s in topics))
    return "\n".join(lines) + "\n"


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
