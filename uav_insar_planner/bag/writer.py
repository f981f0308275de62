"""A rosbag2 bag folder with MCAP storage, as `ros2 bag record -s mcap` leaves it (no ROS import).

    bag = McapBagWriter(Path("mission_bag"))        # refuses a path that exists
    bag.add_topic("/formation", "geometry_msgs/msg/PoseArray", [qos_dict, ...])
    bag.write("/formation", receive_time_ns, serialized_cdr_bytes)
    bag.close()                                     # writes the MCAP index and metadata.yaml

The folder holds `<name>.mcap` and `metadata.yaml` (rosbag2 format version 9, Jazzy). Each
topic's MCAP schema is the full `ros2msg` definition (bag.definitions.full_definition), its
channel carries `offered_qos_profiles` (the publishers' QoS, so `ros2 bag play` offers them
again: a transient-local topic is latched on playback) and the RIHS01 `topic_type_hash`.
The writer is rosbags' (rosbags.rosbag2.Writer); this module only supplies the definitions and
turns plain QoS dictionaries into its types. A QoS dictionary has the keys of rosbag2's
metadata: history, depth, reliability, durability (names as in rclpy's policies, lower case),
and optionally deadline, lifespan, liveliness_lease_duration as {sec, nsec} and liveliness.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import StoragePlugin, Writer

from uav_insar_planner.bag.definitions import canonical_type, full_definition, type_hash

METADATA_VERSION = 9  # rosbag2 in Jazzy
# rmw's "infinite" duration as rosbag2 (Jazzy) dumps it
INFINITE = {"sec": 9223372036, "nsec": 854775807}


def _enum(kind: type, value: Any) -> Any:
    if isinstance(value, int):
        return kind(value)
    return kind.__members__.get(str(value).upper(), kind.UNKNOWN)


def _time(value: Mapping[str, int] | None) -> QosTime:
    value = value or INFINITE
    return QosTime(int(value["sec"]), int(value["nsec"]))


def to_qos(profile: Mapping[str, Any]) -> Qos:
    """A plain QoS dictionary (see the module docstring) as rosbags' Qos."""
    return Qos(history=_enum(QosHistory, profile.get("history", "keep_last")),
               depth=int(profile.get("depth", 0)),
               reliability=_enum(QosReliability, profile.get("reliability", "reliable")),
               durability=_enum(QosDurability, profile.get("durability", "volatile")),
               deadline=_time(profile.get("deadline")),
               lifespan=_time(profile.get("lifespan")),
               liveliness=_enum(QosLiveliness, profile.get("liveliness", "automatic")),
               liveliness_lease_duration=_time(profile.get("liveliness_lease_duration")),
               avoid_ros_namespace_conventions=bool(
                   profile.get("avoid_ros_namespace_conventions", False)))


class McapBagWriter:
    """See the module docstring. Not thread-safe: one thread adds and writes."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self._writer = Writer(self.path, version=METADATA_VERSION,
                              storage_plugin=StoragePlugin.MCAP)
        self._writer.set_custom_data("recorded_by", "uav_insar_planner")
        self._writer.open()
        self._connections: dict[str, Any] = {}
        self.counts: dict[str, int] = {}

    def __contains__(self, topic: str) -> bool:
        return topic in self._connections

    def add_topic(self, topic: str, msg_type: str,
                  offered_qos: Sequence[Mapping[str, Any]] = ()) -> None:
        """Register `topic` of `msg_type` ('pkg/msg/Type') with its publishers' QoS."""
        msg_type = canonical_type(msg_type)
        self._connections[topic] = self._writer.add_connection(
            topic, msg_type, msgdef=full_definition(msg_type), rihs01=type_hash(msg_type),
            serialization_format="cdr", offered_qos_profiles=[to_qos(q) for q in offered_qos])
        self.counts[topic] = 0

    def write(self, topic: str, time_ns: int, data: bytes) -> None:
        """One serialized (CDR) message of a registered topic, stamped `time_ns` (receive time)."""
        self._writer.write(self._connections[topic], int(time_ns), data)
        self.counts[topic] += 1

    def close(self) -> None:
        """Finish the MCAP file and write metadata.yaml."""
        self._writer.close()

    @property
    def mcap_path(self) -> Path:
        return self.path / f"{self.path.name}.mcap"
