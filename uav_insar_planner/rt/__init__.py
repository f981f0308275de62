"""Our rclpy: the subset of rclpy's API that uav_insar_planner's nodes use, over Cyclone DDS,
speaking the ROS 2 Jazzy wire format (see docs/runtime.md). Import it through
`uav_insar_planner.seam`, which prefers the real rclpy when it is installed.

This package object is module-like on purpose: `rclpy.init()`, `rclpy.spin(node)`,
`rclpy.node.Node`, `rclpy.qos.QoSProfile` ... all resolve here.
"""
from __future__ import annotations

from typing import Any

from . import (
    callback_groups,
    clock,
    exceptions,
    executors,
    logging,
    node,
    parameter,
    qos,
    task,
)
from . import clock as duration  # noqa: F401 - rclpy.duration.Duration lives in clock
from . import clock as time  # noqa: F401 - rclpy.time.Time lives in clock
from .arguments import remove_ros_args
from .context import Context, get_default_context, init
from .executors import Executor, MultiThreadedExecutor, SingleThreadedExecutor
from .node import Node

_global_executor: SingleThreadedExecutor | None = None

__all__ = [
    "Context", "Executor", "MultiThreadedExecutor", "Node", "SingleThreadedExecutor",
    "callback_groups", "clock", "create_node", "exceptions", "executors", "get_global_executor",
    "init", "logging", "node", "ok", "parameter", "qos", "remove_ros_args", "shutdown", "spin",
    "spin_once", "spin_until_future_complete", "task", "try_shutdown", "utilities",
]


class _Utilities:
    """rclpy.utilities subset."""

    remove_ros_args = staticmethod(remove_ros_args)

    @staticmethod
    def get_default_context() -> Context:
        return get_default_context()


utilities = _Utilities()


def ok(*, context: Context | None = None) -> bool:
    return (context or get_default_context()).ok()


def shutdown(*, context: Context | None = None, uninstall_handlers: bool | None = None) -> None:
    """Shut the context down; RuntimeError if it is not initialized (as rclpy)."""
    global _global_executor
    (context or get_default_context()).shutdown()
    if context is None and _global_executor is not None:
        _global_executor.shutdown()
        _global_executor = None


def try_shutdown(*, context: Context | None = None,
                 uninstall_handlers: bool | None = None) -> None:
    global _global_executor
    (context or get_default_context()).try_shutdown()
    if context is None and _global_executor is not None:
        _global_executor.shutdown()
        _global_executor = None


def get_global_executor() -> SingleThreadedExecutor:
    global _global_executor
    if _global_executor is None:
        _global_executor = SingleThreadedExecutor()
    return _global_executor


def create_node(node_name: str, **kwargs: Any) -> Node:
    return Node(node_name, **kwargs)


def _executor_for(node: Node, executor: Executor | None) -> Executor:
    if executor is not None:
        return executor
    if node.context is not get_default_context():
        return SingleThreadedExecutor(context=node.context)
    return get_global_executor()


def spin(node: Node, executor: Executor | None = None) -> None:
    """Run the node's callbacks until shutdown; ExternalShutdownException when the context
    is shut down by a signal or another thread while waiting."""
    ex = _executor_for(node, executor)
    ex.add_node(node)
    try:
        ex.spin()
    finally:
        ex.remove_node(node)


def spin_once(node: Node, *, executor: Executor | None = None,
              timeout_sec: float | None = None) -> None:
    ex = _executor_for(node, executor)
    ex.add_node(node)
    try:
        ex.spin_once(timeout_sec=timeout_sec)
    finally:
        ex.remove_node(node)


def spin_until_future_complete(node: Node, future: task.Future,
                               executor: Executor | None = None,
                               timeout_sec: float | None = None) -> None:
    ex = _executor_for(node, executor)
    ex.add_node(node)
    try:
        ex.spin_until_future_complete(future, timeout_sec)
    finally:
        ex.remove_node(node)
