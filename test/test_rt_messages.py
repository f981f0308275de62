"""Generated message classes: bytes equal rosbags' serialize_cdr, decode back, defaults."""
from __future__ import annotations

import numpy as np
import pytest
from rosbags.interfaces import Nodetype

from uav_insar_planner.rt.messages import TYPESTORE, get_message, msg_type, type_hash
from uav_insar_planner.rt.service import csid_string, unwrap, wire_type, wrap

_NUMPY = {"bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8,
          "uint8": np.uint8, "int16": np.int16, "uint16": np.uint16, "int32": np.int32,
          "uint32": np.uint32, "int64": np.int64, "uint64": np.uint64,
          "float32": np.float32, "float64": np.float64}


def to_rosbags(msg, ros_type: str):
    """The same message as a rosbags object, built independently from the typestore."""
    _consts, fields = TYPESTORE.fielddefs[ros_type]
    kwargs = {}
    for name, (kind, rest) in fields:
        value = getattr(msg, name)
        if kind == Nodetype.NAME:
            value = to_rosbags(value, rest)
        elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            (ikind, irest), _size = rest
            if ikind == Nodetype.NAME:
                value = [to_rosbags(v, irest) for v in value]
            elif irest[0] != "string":
                value = np.array(list(value), dtype=_NUMPY[irest[0]])
        kwargs[name] = value
    return TYPESTORE.types[ros_type](**kwargs)


def _samples():
    m = get_message
    stamp = m("builtin_interfaces/msg/Time")(sec=1_700_000_000, nanosec=123_456_789)
    header = m("std_msgs/msg/Header")(stamp=stamp, frame_id="insar_track")
    point = m("geometry_msgs/msg/Point")(x=20.0, y=-3.25, z=47.5)
    quat = m("geometry_msgs/msg/Quaternion")(x=0.1, y=0.2, z=0.3, w=0.9)
    pose = m("geometry_msgs/msg/Pose")(position=point, orientation=quat)
    kv = m("diagnostic_msgs/msg/KeyValue")
    status = m("diagnostic_msgs/msg/DiagnosticStatus")(
        level=m("diagnostic_msgs/msg/DiagnosticStatus").WARN, name="planner: plan",
        message="rate margin low", hardware_id="uav1",
        values=[kv(key="sigma_h", value="0.41"), kv(key="b_perp_01", value="3.2")])
    dim = m("std_msgs/msg/MultiArrayDimension")
    layout = m("std_msgs/msg/MultiArrayLayout")(
        dim=[dim(label="uav", size=3, stride=240), dim(label="slot", size=80, stride=80)],
        data_offset=0)
    gid = m("rmw_dds_common/msg/Gid")
    return [
        ("builtin_interfaces/msg/Time", stamp),
        ("std_msgs/msg/Header", header),
        ("geometry_msgs/msg/Point", point),
        ("geometry_msgs/msg/Quaternion", quat),
        ("geometry_msgs/msg/Pose", pose),
        ("geometry_msgs/msg/PoseStamped", m("geometry_msgs/msg/PoseStamped")(
            header=header, pose=pose)),
        ("geometry_msgs/msg/PoseArray", m("geometry_msgs/msg/PoseArray")(
            header=header, poses=[pose, m("geometry_msgs/msg/Pose")()])),
        ("geometry_msgs/msg/PoseArray", m("geometry_msgs/msg/PoseArray")()),
        ("std_msgs/msg/Float64", m("std_msgs/msg/Float64")(data=16.95e6)),
        ("std_msgs/msg/String", m("std_msgs/msg/String")(data="héllo ✓")),
        ("std_msgs/msg/MultiArrayDimension", dim(label="slot", size=80, stride=80)),
        ("std_msgs/msg/MultiArrayLayout", layout),
        ("std_msgs/msg/Float64MultiArray", m("std_msgs/msg/Float64MultiArray")(
            layout=layout, data=np.linspace(0.0, 1.0, 240))),
        ("diagnostic_msgs/msg/KeyValue", kv(key="k", value="v")),
        ("diagnostic_msgs/msg/DiagnosticStatus", status),
        ("diagnostic_msgs/msg/DiagnosticArray", m("diagnostic_msgs/msg/DiagnosticArray")(
            header=header, status=[status, status])),
        ("std_srvs/srv/Trigger_Request", msg_type("std_srvs/srv/Trigger").Request()),
        ("std_srvs/srv/Trigger_Response", msg_type("std_srvs/srv/Trigger").Response(
            success=True, message="replanned")),
        ("rmw_dds_common/msg/Gid", gid(data=bytes(range(16)))),
        ("rmw_dds_common/msg/ParticipantEntitiesInfo",
         m("rmw_dds_common/msg/ParticipantEntitiesInfo")(
             gid=gid(data=bytes(range(16, 32))), node_entities_info_seq=[
                 m("rmw_dds_common/msg/NodeEntitiesInfo")(
                     node_namespace="/", node_name="planner",
                     reader_gid_seq=[gid(data=bytes(16))],
                     writer_gid_seq=[gid(data=bytes(range(16))), gid(data=b"\xff" * 16)])])),
    ]


@pytest.mark.parametrize(("ros_type", "msg"), _samples(),
                         ids=[f"{t}-{i}" for i, (t, _) in enumerate(_samples())])
def test_bytes_equal_rosbags_and_round_trip(ros_type, msg):
    ours = msg.serialize()
    assert ours[:4] == b"\x00\x01\x00\x00"  # XCDR1, little endian
    theirs = bytes(TYPESTORE.serialize_cdr(to_rosbags(msg, ros_type), ros_type))
    assert ours == theirs
    back = type(msg).deserialize(theirs)
    assert back.serialize() == ours
    decoded = TYPESTORE.deserialize_cdr(ours, ros_type)
    assert bytes(TYPESTORE.serialize_cdr(decoded, ros_type)) == ours


def test_names_defaults_and_construction():
    pose_cls = get_message("geometry_msgs/msg/Pose")
    assert pose_cls.__idl_typename__ == "geometry_msgs::msg::dds_::Pose_"
    assert msg_type("std_srvs/srv/Trigger").Request.__idl_typename__ == \
        "std_srvs::srv::dds_::Trigger_Request_"
    pose = pose_cls()
    assert (pose.orientation.x, pose.orientation.w) == (0.0, 1.0)  # the .msg default
    a, b = pose_cls(), pose_cls()
    a.position.x = 5.0
    assert b.position.x == 0.0  # nested defaults are not shared
    arr = get_message("geometry_msgs/msg/PoseArray")()
    arr.poses.append(pose)
    assert get_message("geometry_msgs/msg/PoseArray")().poses == []
    status_cls = get_message("diagnostic_msgs/msg/DiagnosticStatus")
    assert (status_cls.OK, status_cls.WARN, status_cls.ERROR) == (0, 1, 2)
    status = status_cls(level=b"\x02")  # rclpy's byte form is accepted
    assert status.level == status_cls.ERROR
    assert type_hash("geometry_msgs/msg/PoseArray").startswith("RIHS01_")
    with pytest.raises(KeyError):
        get_message("nope_msgs/msg/Nothing")


def test_service_wire_layout():
    trigger = msg_type("std_srvs/srv/Trigger")
    resp = trigger.Response(success=True, message="ok")
    raw = wrap(resp, guid=0x0102030405060708, seq=7).serialize()
    assert raw[:4] == b"\x00\x01\x00\x00"
    assert raw[4:12] == (0x0102030405060708).to_bytes(8, "little")
    assert raw[12:20] == (7).to_bytes(8, "little")
    assert raw[20:] == resp.serialize()[4:]  # the response fields follow, aligned the same
    back = wire_type(trigger.Response).deserialize(raw)
    assert unwrap(back, trigger.Response) == resp
    assert csid_string(bytes([1, 0xAB] + [0] * 13 + [5])) == " 1.ab" + ".0" * 13 + ".5"
