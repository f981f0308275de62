"""The ROS graph on DDS: our `ros_discovery_info` announcements (what `ros2 node list`
reads) and queries of the endpoints DDS discovery has seen."""
from __future__ import annotations

import threading
from typing import Any

from cyclonedds.builtin import (
    BuiltinDataReader,
    BuiltinTopicDcpsPublication,
    BuiltinTopicDcpsSubscription,
)
from cyclonedds.core import InstanceState
from cyclonedds.pub import DataWriter
from cyclonedds.topic import Topic

from .messages import get_message, type_hash
from .qos import DurabilityPolicy, QoSProfile, to_dds

DISCOVERY_TOPIC = "ros_discovery_info"
PEI_TYPE = "rmw_dds_common/msg/ParticipantEntitiesInfo"
DISCOVERY_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def gid_of(entity: Any) -> bytes:
    """An entity's rmw gid: its 16-byte DDS GUID."""
    return entity.get_guid().bytes


class GraphAnnouncer:
    """Publishes this participant's complete node list on every change (rmw_dds_common)."""

    def __init__(self, participant: Any) -> None:
        self._pei = get_message(PEI_TYPE)
        self._gid_cls = get_message("rmw_dds_common/msg/Gid")
        self._nei = get_message("rmw_dds_common/msg/NodeEntitiesInfo")
        topic = Topic(participant, DISCOVERY_TOPIC, self._pei)
        self._writer = DataWriter(participant, topic, to_dds(
            DISCOVERY_QOS, f"typehash={type_hash(PEI_TYPE)};", writer=True))
        self.gid = gid_of(participant)
        self._lock = threading.Lock()

    def publish(self, nodes: list[tuple[str, str, list[bytes], list[bytes]]]) -> None:
        """nodes: (namespace, name, reader gids, writer gids) for every live node."""
        msg = self._pei(gid=self._gid_cls(data=self.gid), node_entities_info_seq=[
            self._nei(node_namespace=ns, node_name=name,
                      reader_gid_seq=[self._gid_cls(data=g) for g in readers],
                      writer_gid_seq=[self._gid_cls(data=g) for g in writers])
            for ns, name, readers, writers in nodes])
        with self._lock:
            self._writer.write(msg)


class GraphQuery:
    """Endpoints known to DDS discovery (all participants in the domain, ours included)."""

    def __init__(self, participant: Any) -> None:
        self._pubs = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
        self._subs = BuiltinDataReader(participant, BuiltinTopicDcpsSubscription)

    @staticmethod
    def _alive(reader: Any) -> list[Any]:
        return [s for s in reader.read(N=100_000)
                if s.sample_info.valid_data
                and s.sample_info.instance_state == InstanceState.Alive]

    def publications(self) -> list[Any]:
        """DcpsEndpoint samples (topic_name, type_name, qos, key) of live writers."""
        return self._alive(self._pubs)

    def subscriptions(self) -> list[Any]:
        return self._alive(self._subs)
