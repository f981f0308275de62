"""The one place node code gets its ROS API from.

With a sourced ROS 2 (``import rclpy`` works) this re-exports rclpy and the generated message
packages; otherwise our runtime on Cyclone DDS (`uav_insar_planner.rt`) with the same names
and semantics. ``UAV_INSAR_RUNTIME=embedded`` forces our runtime even where rclpy exists.

    from uav_insar_planner.seam import rclpy, Node, QoSProfile, msg_type
    PoseArray = msg_type("geometry_msgs/msg/PoseArray")
"""
from __future__ import annotations

import importlib
import os

_FORCE_EMBEDDED = os.environ.get("UAV_INSAR_RUNTIME", "").strip().lower() == "embedded"

try:
    if _FORCE_EMBEDDED:
        raise ImportError("UAV_INSAR_RUNTIME=embedded")
    import rclpy  # type: ignore[no-redef]
    from rcl_interfaces.msg import (
        FloatingPointRange,
        IntegerRange,
        ParameterDescriptor,
        ParameterType,
        SetParametersResult,
    )
    from rclpy.executors import (
        ExternalShutdownException,
        MultiThreadedExecutor,
        SingleThreadedExecutor,
    )
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from rclpy.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        QoSProfile,
        ReliabilityPolicy,
        qos_profile_sensor_data,
    )

    USING_RCLPY = True

    def msg_type(name: str) -> type:
        """Message or service class by ROS name, e.g. 'std_srvs/srv/Trigger'."""
        pkg, kind, cls = name.split("/")
        return getattr(importlib.import_module(f"{pkg}.{kind}"), cls)

except ImportError:
    from . import rt as rclpy  # noqa: F401 - re-exported
    from .rt.exceptions import ExternalShutdownException
    from .rt.executors import MultiThreadedExecutor, SingleThreadedExecutor
    from .rt.messages import msg_type
    from .rt.node import Node
    from .rt.parameter import (
        FloatingPointRange,
        IntegerRange,
        Parameter,
        ParameterDescriptor,
        ParameterType,
        SetParametersResult,
    )
    from .rt.qos import (
        DurabilityPolicy,
        HistoryPolicy,
        QoSProfile,
        ReliabilityPolicy,
        qos_profile_sensor_data,
    )

    USING_RCLPY = False

__all__ = [
    "USING_RCLPY", "DurabilityPolicy", "ExternalShutdownException", "FloatingPointRange",
    "HistoryPolicy", "IntegerRange", "MultiThreadedExecutor", "Node", "Parameter",
    "ParameterDescriptor", "ParameterType", "QoSProfile", "ReliabilityPolicy",
    "SetParametersResult", "SingleThreadedExecutor", "msg_type", "qos_profile_sensor_data",
    "rclpy",
]
