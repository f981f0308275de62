"""The ROS side of `uav-insar echo` (cli/echo.py, which parses and documents it): subscribe to
a topic on rclpy as `ros2 topic echo` does and print each message as YAML.

TOPIC is resolved as ros2 resolves it (`formation` -> `/formation`, or under the namespace
given by `--ros-args -r __ns:=/uav1`). The echo waits for a publisher on it, takes the message
type from the ROS graph and matches the publishers' QoS: reliable only if all of them are
reliable, transient_local only if all of them are (so a late echo gets latched topics such as
/formation), depth 10. Each message prints as YAML (`msg_yaml.message_to_yaml`) and a `---`
line, flushed at once. After SIGINT or SIGTERM further signals are ignored while the echo
cleans up and exits.
"""
from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading
import time
from typing import Any

from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_CRASH, EXIT_OK, CommandFailed
from uav_insar_planner.ros.tools.msg_yaml import TRUNCATE_LENGTH, message_to_yaml

ECHO_DEPTH = 10  # as ros2 topic echo

PROG = "uav-insar echo"


def _first_line(exc: BaseException) -> str:
    return str(exc).strip().splitlines()[0].rstrip(":") if str(exc).strip() else repr(exc)


def _interrupt(signum: int, frame: Any) -> None:
    # One signal ends the echo; more during the clean-up (or Python's exit) must not cut it
    # short, so from now on they are ignored.
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)
    raise KeyboardInterrupt


def echo(args: argparse.Namespace) -> int:
    """Echo `args.topic` (args of cli/echo.py, `args.ros_args` for rcl); the exit code, or
    CommandFailed with the code of a failure."""
    previous = {}  # SIGINT too, in case it came in ignored
    if threading.current_thread() is threading.main_thread():
        previous = {s: signal.signal(s, _interrupt) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        return _echo(args)
    except KeyboardInterrupt:
        previous = {}  # stay deaf to signals while Python exits (see _interrupt)
        return EXIT_OK
    except BrokenPipeError:  # e.g. `| head`: stop quietly, and keep Python's exit flush quiet
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _bad(text: str) -> CommandFailed:
    return CommandFailed(text, EXIT_BAD_INPUT)


def check_ros_args(ros_args: list[str]) -> None:
    """CommandFailed (EXIT_BAD_INPUT) unless rcl parses `ros_args`; asked before rclpy.init,
    which would log its own `[ERROR]` line about them first."""
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from rclpy.utilities import remove_ros_args

    try:
        remove_ros_args([PROG, *ros_args])
    except (_rclpy.RCLError, _rclpy.UnknownROSArgsError) as exc:
        raise _bad(f"bad ROS arguments: {_first_line(exc)}") from None


def _echo(args: argparse.Namespace) -> int:
    import rclpy
    from rclpy.exceptions import InvalidTopicNameException, NameValidationException
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from rclpy.signals import SignalHandlerOptions
    from rclpy.validate_full_topic_name import validate_full_topic_name
    from rclpy.validate_topic_name import validate_topic_name

    check_ros_args(args.ros_args)
    try:
        validate_topic_name(args.topic)
    except InvalidTopicNameException as exc:
        raise _bad(_first_line(exc)) from None
    end = None if args.timeout is None else time.monotonic() + args.timeout
    want = 1 if args.once else args.count
    context = rclpy.Context()
    try:
        rclpy.init(args=[PROG, *args.ros_args], context=context,
                   signal_handler_options=SignalHandlerOptions.NO)
    except (_rclpy.RCLError, _rclpy.UnknownROSArgsError) as exc:
        raise _bad(f"bad ROS arguments: {_first_line(exc)}") from None
    node = executor = None
    try:
        try:
            node = rclpy.create_node(f"_uav_insar_echo_{os.getpid()}", context=context,
                                     start_parameter_services=False, enable_rosout=False)
        except (_rclpy.RCLError, NameValidationException) as exc:
            raise _bad(f"bad ROS arguments: {_first_line(exc)}") from None
        try:
            topic = node.resolve_topic_name(args.topic)
            validate_full_topic_name(topic)
        except (_rclpy.RCLError, InvalidTopicNameException) as exc:
            raise _bad(_first_line(exc)) from None
        msg_type, qos = _wait_for_publishers(node, topic, end, args.timeout)
        received = 0

        def show(msg: Any) -> None:
            nonlocal received
            received += 1
            sys.stdout.write(message_to_yaml(
                msg, truncate_length=None if args.full_length else TRUNCATE_LENGTH) + "---\n")
            sys.stdout.flush()

        node.create_subscription(msg_type, topic, show, qos)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        while want is None or received < want:
            step = 0.1 if end is None else min(0.1, end - time.monotonic())
            if step <= 0:
                break
            executor.spin_once(timeout_sec=step)
        if not received:
            raise CommandFailed(f"no message on {topic} within {args.timeout:g} s", EXIT_CRASH)
        return EXIT_OK
    except ExternalShutdownException:
        return EXIT_OK
    finally:
        if executor is not None:
            executor.shutdown(timeout_sec=0)
        if node is not None:
            node.destroy_node()
        context.try_shutdown()


def _wait_for_publishers(node: Any, topic: str, end: float | None,
                         timeout: float | None) -> tuple[type, Any]:
    """The message class on `topic` and a QoS profile matching its publishers, once it has any."""
    from uav_insar_planner.ros.topics import matching_qos

    while True:
        infos = [i for i in node.get_publishers_info_by_topic(topic)  # not our own publishers
                 if (i.node_name, i.node_namespace) != (node.get_name(), node.get_namespace())]
        types = dict(node.get_topic_names_and_types()).get(topic)
        if infos and types:
            break
        if end is not None and time.monotonic() >= end:
            raise CommandFailed(f"no publisher on {topic} within {timeout:g} s", EXIT_CRASH)
        time.sleep(0.05)
    if len(types) > 1:
        raise CommandFailed(f"{topic} has more than one type: {', '.join(types)}", EXIT_CRASH)
    return message_class(types[0], topic), matching_qos([i.qos_profile for i in infos], ECHO_DEPTH)


def message_class(type_name: str, topic: str) -> type:
    """The Python class of ROS type `pkg/msg/Name`."""
    try:
        package, kind, name = type_name.split("/")
        cls = getattr(importlib.import_module(f"{package}.{kind}"), name)
        if not hasattr(cls, "get_fields_and_field_types"):
            raise TypeError("not a message class")
    except (ValueError, ImportError, AttributeError, TypeError) as exc:
        raise CommandFailed(f"cannot import message type {type_name} of {topic}: "
                            f"{_first_line(exc)}", EXIT_CRASH) from None
    return cls
