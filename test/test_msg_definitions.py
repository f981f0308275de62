"""Message definitions for the bag schemas: the rosbag2 `ros2msg` layout, decodable by the
independent readers, and the type hash rclpy itself announces."""
from __future__ import annotations

import pytest

from uav_insar_planner.bag.definitions import (
    DefinitionError,
    dependencies,
    full_definition,
    interface_file,
    type_hash,
)

SUITE_TYPES = ("geometry_msgs/msg/PoseArray", "geometry_msgs/msg/PoseStamped",
               "std_msgs/msg/Float64", "std_msgs/msg/Float64MultiArray",
               "diagnostic_msgs/msg/DiagnosticArray", "visualization_msgs/msg/MarkerArray")
BAR = "=" * 80


def _msg(name: str) -> str:
    return interface_file(name, ".msg").read_text()


def test_the_layout_is_rosbag2s_depth_first_sorted_each_once():
    expected = (_msg("std_msgs/msg/Float64MultiArray")
                + f"\n{BAR}\nMSG: std_msgs/MultiArrayLayout\n" + _msg("std_msgs/MultiArrayLayout")
                + f"\n{BAR}\nMSG: std_msgs/MultiArrayDimension\n"
                + _msg("std_msgs/MultiArrayDimension"))
    assert full_definition("std_msgs/msg/Float64MultiArray") == expected
    text = full_definition("geometry_msgs/msg/PoseArray")
    headers = [line for line in text.splitlines() if line.startswith("MSG: ")]
    # sorted per type, depth first: geometry_msgs/Pose (and its Point, Quaternion), then
    # std_msgs/Header (and its Time)
    assert headers == ["MSG: geometry_msgs/Pose", "MSG: geometry_msgs/Point",
                       "MSG: geometry_msgs/Quaternion", "MSG: std_msgs/Header",
                       "MSG: builtin_interfaces/Time"]


def test_constants_arrays_and_builtins_add_no_dependency():
    text = "uint8 ARROW=0\nstring NAME = x\n# a comment\nfloat64[] data\nPoint[<=3] pts  # c\n" \
           "string<=5 s\nstd_msgs/Header header\nHeader h2\n"
    assert dependencies(text, "geometry_msgs") == ["geometry_msgs/Point", "std_msgs/Header"]


@pytest.mark.parametrize("name", SUITE_TYPES)
def test_every_suite_type_decodes_with_mcap_ros2_and_rosbags(name):
    from mcap_ros2._dynamic import generate_dynamic
    from rosbags.typesys import get_types_from_msg

    text = full_definition(name)
    assert name in generate_dynamic(name, text)
    used = {line[5:].replace("/", "/msg/") for line in text.splitlines()
            if line.startswith("MSG: ")}
    assert set(get_types_from_msg(text, name)) == {name} | used


def test_the_hash_is_the_one_rclpy_announces(ros_context):
    import importlib

    import rclpy

    node = rclpy.create_node("hash_probe", context=ros_context)
    try:
        for i, name in enumerate(SUITE_TYPES):
            package, _, cls = name.split("/")
            node.create_publisher(getattr(importlib.import_module(f"{package}.msg"), cls),
                                  f"/probe{i}", 1)
            (info,) = node.get_publishers_info_by_topic(f"/probe{i}")
            assert type_hash(name) == str(info.topic_type_hash), name
    finally:
        node.destroy_node()


def test_an_unknown_type_is_one_clear_error():
    with pytest.raises(DefinitionError, match="no_such_msgs/msg/Thing"):
        full_definition("no_such_msgs/msg/Thing")
    with pytest.raises(ValueError, match="package/msg/Type"):
        full_definition("not a type")
