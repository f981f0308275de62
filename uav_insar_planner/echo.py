"""`uav-insar echo TOPIC`: print a topic's messages as `ros2 topic echo` does.

The message type is the one the topic's writers announce in DDS discovery; the subscription's
reliability and durability follow the writers (reliable / transient_local only when every
writer offers it), as ros2 topic echo adapts its QoS. Always runs on our runtime.

Exit codes: 0 when --count messages arrived, on Ctrl-C, or when --timeout ran out after at
least one message; 1 when --timeout ran out with no publisher or no message; 2 for bad usage.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from typing import Any

import yaml

from . import rt
from .rt.exceptions import ExternalShutdownException
from .rt.messages import get_message, ros_typename
from .rt.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy


def to_plain(value: Any) -> Any:
    """A message as nested dicts/lists/scalars in field order (rosidl_runtime_py style)."""
    if dataclasses.is_dataclass(value):
        return {f.name: to_plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, (bytes, bytearray)):
        return list(value)
    if isinstance(value, (list, tuple)):
        return [to_plain(v) for v in value]
    return value


def to_yaml(msg: Any) -> str:
    """The text ros2 topic echo prints for one message (without the `---`)."""
    return yaml.safe_dump(to_plain(msg), default_flow_style=False, sort_keys=False,
                          allow_unicode=True, width=2**31 - 1)


def _writers(node: Any, dds_topic: str) -> list[Any]:
    return [e for e in node.context.graph_query().publications() if e.topic_name == dds_topic]


def _qos_for(writers: list[Any]) -> QoSProfile:
    from cyclonedds.core import Policy

    reliable = all(w.qos[Policy.Reliability] != Policy.Reliability.BestEffort for w in writers)
    latched = all(w.qos[Policy.Durability] == Policy.Durability.TransientLocal for w in writers)
    return QoSProfile(
        depth=10,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def main(argv: list[str] | None = None) -> int:
    """Run `echo`; returns the exit code (see the module docstring)."""
    parser = argparse.ArgumentParser(prog="uav-insar echo",
                                     description="Print a ROS 2 topic like ros2 topic echo.")
    parser.add_argument("topic", help="topic name, e.g. /formation")
    parser.add_argument("--count", type=int, default=0,
                        help="exit after this many messages (default: run until Ctrl-C)")
    parser.add_argument("--timeout", type=float, default=None,
                        help="give up after this many seconds")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    end = None if args.timeout is None else time.monotonic() + args.timeout
    context = rt.Context()
    rt.init(args=["uav-insar-echo"], context=context)
    node = rt.Node("uav_insar_echo", context=context)
    received = 0
    try:
        topic = node.resolve_topic_name(args.topic)
        writers: list[Any] = []
        while not writers:
            writers = _writers(node, "rt" + topic)
            if end is not None and time.monotonic() >= end:
                print(f"uav-insar echo: no publisher on {topic} within {args.timeout:g} s; "
                      "cannot tell its type", file=sys.stderr)
                return 1
            if not writers:
                time.sleep(0.05)
        msg_cls = get_message(ros_typename(writers[0].type_name))

        def show(msg: Any) -> None:
            nonlocal received
            received += 1
            sys.stdout.write(to_yaml(msg) + "---\n")
            sys.stdout.flush()

        node.create_subscription(msg_cls, topic, show, _qos_for(writers))
        executor = rt.SingleThreadedExecutor(context=context)
        executor.add_node(node)
        while not args.count or received < args.count:
            remaining = None if end is None else end - time.monotonic()
            if remaining is not None and remaining <= 0:
                break
            executor.spin_once(timeout_sec=remaining)
    except (KeyboardInterrupt, ExternalShutdownException):
        return 0
    finally:
        context.try_shutdown()
    return 0 if received else 1


if __name__ == "__main__":
    raise SystemExit(main())
