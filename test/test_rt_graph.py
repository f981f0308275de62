"""What a Jazzy machine reads from us: ros_discovery_info, USER_DATA, topic/type names —
checked with raw Cyclone DDS readers, not with our runtime."""
from __future__ import annotations

import signal
import time

from cyclonedds.builtin import (
    BuiltinDataReader,
    BuiltinTopicDcpsParticipant,
    BuiltinTopicDcpsPublication,
    BuiltinTopicDcpsSubscription,
)
from cyclonedds.core import Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from uav_insar_planner.rt.discovery import cyclone_config, ensure_domain
from uav_insar_planner.rt.messages import get_message, type_hash


def _wait(fn, timeout=10.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = fn()
        if value:
            return value
        time.sleep(0.05)
    return fn()


def _userdata(qos) -> str:
    ud = qos[Policy.Userdata]
    return ud.data.decode() if ud else ""


def test_ros_discovery_info_and_user_data(children, ros_domain):
    talker = children.start("talker")
    server = children.start("server", "--ros-args", "-r", "__ns:=/planner_ns")
    assert talker.stdout.readline().strip() == "ready"
    assert server.stdout.readline().strip() == "ready"
    ensure_domain(ros_domain)
    dp = DomainParticipant(ros_domain)
    pei = get_message("rmw_dds_common/msg/ParticipantEntitiesInfo")
    reader = DataReader(dp, Topic(dp, "ros_discovery_info", pei), Qos(
        Policy.Reliability.Reliable(duration(seconds=1)), Policy.Durability.TransientLocal,
        Policy.History.KeepAll))

    nodes: dict[tuple[str, str], object] = {}

    def collect():
        for s in reader.take(N=100):
            for n in s.node_entities_info_seq:
                nodes[(n.node_namespace, n.node_name)] = n
        return ("/", "talker") in nodes and ("/planner_ns", "server") in nodes

    assert _wait(collect), nodes
    talker_info = nodes[("/", "talker")]
    # Every node also serves the six parameter services (one reader and one writer each) and
    # publishes /parameter_events.
    assert len(talker_info.writer_gid_seq) == 2 + 6 + 1  # /formation and /chatter
    server_info = nodes[("/planner_ns", "server")]
    assert len(server_info.reader_gid_seq) == 1 + 6
    assert len(server_info.writer_gid_seq) == 1 + 6 + 1

    pubs = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
    subs = BuiltinDataReader(dp, BuiltinTopicDcpsSubscription)
    parts = BuiltinDataReader(dp, BuiltinTopicDcpsParticipant)
    seen_pubs: dict[str, object] = {}
    seen_subs: dict[str, object] = {}

    def endpoints():
        seen_pubs.update({e.topic_name: e for e in pubs.take(N=200)
                          if e.sample_info.valid_data})
        seen_subs.update({e.topic_name: e for e in subs.take(N=200)
                          if e.sample_info.valid_data})
        return {"rt/formation", "rq/planner/replanRequest"} <= seen_subs.keys() | \
            seen_pubs.keys() and "rr/planner/replanReply" in seen_pubs

    assert _wait(endpoints), (seen_pubs.keys(), seen_subs.keys())
    formation = seen_pubs["rt/formation"]
    assert formation.type_name == "geometry_msgs::msg::dds_::PoseArray_"
    assert _userdata(formation.qos) == f"typehash={type_hash('geometry_msgs/msg/PoseArray')};"
    assert formation.qos[Policy.Durability] == Policy.Durability.TransientLocal
    assert formation.qos[Policy.DurabilityService].history == Policy.History.KeepLast(1)
    reply = seen_pubs["rr/planner/replanReply"]
    assert reply.type_name == "std_srvs::srv::dds_::Trigger_Response_"
    assert _userdata(reply.qos).startswith("serviceid=")
    assert _userdata(reply.qos).endswith(
        f";typehash={type_hash('std_srvs/srv/Trigger_Response')};")
    request = seen_subs["rq/planner/replanRequest"]
    assert request.type_name == "std_srvs::srv::dds_::Trigger_Request_"
    assert _userdata(request.qos).split(";")[0] == _userdata(reply.qos).split(";")[0]

    enclaves = _wait(lambda: [p for p in parts.read(N=50)
                              if p.sample_info.valid_data and p.qos[Policy.Userdata]])
    assert all(_userdata(p.qos) == "enclave=/;" for p in enclaves)


def test_sigterm_and_sigint_shut_down_cleanly(children):
    for sig in (signal.SIGTERM, signal.SIGINT):
        proc = children.start("talker")
        assert proc.stdout.readline().strip() == "ready"
        proc.send_signal(sig)
        _out, err = proc.communicate(timeout=10)
        assert proc.returncode == 0, err
        assert "Traceback" not in err


def test_discovery_config_choices():
    assert cyclone_config({"CYCLONEDDS_URI": "file:///x.xml"}) is None
    local = cyclone_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    assert '<NetworkInterface address="127.0.0.1"/>' in local
    assert "<AllowMulticast>false</AllowMulticast>" in local
    assert '<Peer address="127.0.0.1"/>' in local
    default = cyclone_config({})
    assert "AllowMulticast" not in default and '<Peer address="127.0.0.1"/>' in default
    off = cyclone_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"})
    assert "<Peer " not in off
    peers = cyclone_config({"ROS_STATIC_PEERS": "10.0.0.5;10.0.0.6"})
    assert '<Peer address="10.0.0.5"/>' in peers and '<Peer address="10.0.0.6"/>' in peers
