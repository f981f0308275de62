"""rosbag2's metadata as Jazzy writes it (no ROS import): the BagMetadata mapping of
metadata.yaml and of the MCAP `rosbag2` record, and the QoS profiles of a topic.

Read from rosbag2 0.26 (its jazzy branch, commit 64717ee8; file:line there):
- `bag_metadata(...)` is rosbag2_storage/include/rosbag2_storage/yaml.hpp:257-275
  (convert<BagMetadata>::encode), with TopicInformation (:149-156), TopicMetadata (:108-122),
  FileInformation (:197-204), nanoseconds as {nanoseconds} (:221-226) and time points as
  {nanoseconds_since_epoch} (:238-243); the values are rosbag2_cpp's SequentialWriter's
  (src/rosbag2_cpp/writers/sequential_writer.cpp:75-94 init_metadata, :382-431 write,
  :502-522 finalize_metadata). metadata.yaml wraps it in `rosbag2_bagfile_information`
  (rosbag2_storage/src/rosbag2_storage/metadata_io.cpp:32-38).
- `qos_profile(...)` is rosbag2_storage/src/rosbag2_storage/qos.cpp:151-165
  (convert<rclcpp::QoS>::encode, version 9: policies as rmw's names, rmw/src/
  qos_string_conversions.c), a topic's list :251-258; the MCAP channel holds it as YAML text
  (serialize_rclcpp_qos_vector, qos.cpp:441-445).
- `dump(...)` writes YAML as yaml-cpp does (block style, sequences indented under their key,
  `""` for an empty string, `~` for null, no final newline), so the text reads like rosbag2's.

The distro (`ros_distro`): rosbag2 stores the ROS_DISTRO environment variable
(sequential_writer.cpp:89); a sourced Jazzy sets it to `jazzy`, the PyPI wheels set nothing,
so an unset or empty ROS_DISTRO gives ROS_DISTRO, the distro whose format this writes.
"""
from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import yaml

METADATA_VERSION = 9  # rosbag2_storage/bag_metadata.hpp:45 in Jazzy
ROS_DISTRO = "jazzy"
STORAGE_IDENTIFIER = "mcap"  # rosbag2_storage_mcap's get_storage_identifier()
SERIALIZATION_FORMAT = "cdr"
# rmw's RMW_DURATION_INFINITE (rmw/time.h:54) as qos.cpp dumps an rmw_time_t
INFINITE = {"sec": 9223372036, "nsec": 854775807}
# std::chrono::nanoseconds::max(): rosbag2's starting_time until a first message arrives
NO_MESSAGE_YET_NS = 2**63 - 1
# rmw's enum order (rmw/types.h), for profiles given as numbers; names are rmw's _to_str
_POLICIES = {
    "history": ("system_default", "keep_last", "keep_all", "unknown"),
    "reliability": ("system_default", "reliable", "best_effort", "unknown", "best_available"),
    "durability": ("system_default", "transient_local", "volatile", "unknown", "best_available"),
    "liveliness": ("system_default", "automatic", "", "manual_by_topic", "unknown",
                   "best_available"),
}
_DEFAULTS = {"history": "keep_last", "reliability": "reliable", "durability": "volatile",
             "liveliness": "automatic"}


def ros_distro() -> str:
    """The distro a bag records: ROS_DISTRO if set and not empty, else ROS_DISTRO (jazzy)."""
    return os.environ.get("ROS_DISTRO") or ROS_DISTRO


def _policy(kind: str, value: Any) -> str:
    names = _POLICIES[kind]
    if isinstance(value, int) and 0 <= value < len(names) and names[value]:
        return names[value]
    name = str(value).lower()
    return name if name in names else "unknown"  # what rosbag2 writes for an unknown policy


def _duration(value: Mapping[str, int] | None) -> dict[str, int]:
    value = INFINITE if value is None else value
    return {"sec": int(value["sec"]), "nsec": int(value["nsec"])}


def qos_profile(profile: Mapping[str, Any]) -> dict[str, Any]:
    """A QoS dictionary (history, depth, reliability, durability, deadline, lifespan,
    liveliness, liveliness_lease_duration, avoid_ros_namespace_conventions; policies as rclpy's
    names in lower case or rmw's numbers, durations as {sec, nsec}, missing ones infinite) with
    the keys, key order and values of rosbag2 Jazzy's offered_qos_profiles entry."""
    return {
        "history": _policy("history", profile.get("history", _DEFAULTS["history"])),
        "depth": int(profile.get("depth", 0)),
        "reliability": _policy("reliability",
                               profile.get("reliability", _DEFAULTS["reliability"])),
        "durability": _policy("durability", profile.get("durability", _DEFAULTS["durability"])),
        "deadline": _duration(profile.get("deadline")),
        "lifespan": _duration(profile.get("lifespan")),
        "liveliness": _policy("liveliness", profile.get("liveliness", _DEFAULTS["liveliness"])),
        "liveliness_lease_duration": _duration(profile.get("liveliness_lease_duration")),
        "avoid_ros_namespace_conventions": bool(
            profile.get("avoid_ros_namespace_conventions", False)),
    }


def topic_information(name: str, msg_type: str, offered: Sequence[Mapping[str, Any]],
                      type_hash: str, count: int) -> dict[str, Any]:
    """One entry of topics_with_message_count (yaml.hpp:105-121, :148-156)."""
    return {"topic_metadata": {"name": name, "type": msg_type,
                               "serialization_format": SERIALIZATION_FORMAT,
                               "offered_qos_profiles": [qos_profile(q) for q in offered],
                               "type_description_hash": type_hash},
            "message_count": int(count)}


def bag_metadata(file_name: str, topics: Sequence[Mapping[str, Any]], start_ns: int,
                 duration_ns: int, custom_data: Mapping[str, str] | None,
                 distro: str) -> dict[str, Any]:
    """The BagMetadata of a one-file bag: `topics` from topic_information, `start_ns` the first
    receive time (NO_MESSAGE_YET_NS in a bag without messages), `duration_ns` the last minus
    the first."""
    count = sum(int(t["message_count"]) for t in topics)
    start = {"nanoseconds_since_epoch": int(start_ns)}
    duration = {"nanoseconds": int(duration_ns)}
    return {
        "version": METADATA_VERSION,
        "storage_identifier": STORAGE_IDENTIFIER,
        "duration": duration,
        "starting_time": start,
        "message_count": count,
        "topics_with_message_count": list(topics),
        "compression_format": "",  # no compression (rosbag2's default)
        "compression_mode": "",
        "relative_file_paths": [file_name],
        "files": [{"path": file_name, "starting_time": dict(start), "duration": dict(duration),
                   "message_count": count}],
        "custom_data": dict(custom_data) if custom_data else None,  # an empty map dumps as ~
        "ros_distro": distro,
    }


def metadata_file(metadata: Mapping[str, Any]) -> str:
    """The text of metadata.yaml (metadata_io.cpp:32-38)."""
    return dump({"rosbag2_bagfile_information": dict(metadata)})


class _YamlCppDumper(yaml.SafeDumper):
    def increase_indent(self, flow: bool = False, indentless: bool = False) -> None:
        return super().increase_indent(flow, False)


def _str(dumper: yaml.SafeDumper, value: str) -> yaml.Node:
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style='"' if not value else None)


def _null(dumper: yaml.SafeDumper, value: None) -> yaml.Node:
    return dumper.represent_scalar("tag:yaml.org,2002:null", "~")


_YamlCppDumper.add_representer(str, _str)
_YamlCppDumper.add_representer(type(None), _null)


def dump(node: Any) -> str:
    """`node` as yaml-cpp's YAML::Dump writes it (see the module docstring)."""
    return yaml.dump(node, Dumper=_YamlCppDumper, sort_keys=False, default_flow_style=False,
                     allow_unicode=True, width=2**31 - 1).rstrip("\n")
