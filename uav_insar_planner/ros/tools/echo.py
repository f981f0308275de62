"""`uav-insar echo TOPIC`: print a topic's messages as `ros2 topic echo` does, on rclpy.

    uav-insar echo TOPIC [--once | --count N] [--timeout S] [--full-length] [--ros-args ...]
    python -m uav_insar_planner.ros.tools.echo TOPIC ...

TOPIC is resolved as ros2 resolves it (`formation` -> `/formation`, or under the namespace
given by `--ros-args -r __ns:=/uav1`). The echo waits for a publisher on it, takes the message
type from the ROS graph and matches the publishers' QoS: reliable only if all of them are
reliable, transient_local only if all of them are (so a late echo gets latched topics such as
/formation), depth 10. Each message prints as YAML (`msg_yaml.message_to_yaml`) and a `---`
line, flushed at once.

Options:
  --once          exit after the first message (same as --count 1)
  --count N       exit after N messages (default: run until SIGINT or SIGTERM)
  --timeout S     give up S seconds after start (the wait for a publisher included)
  --full-length   print strings and arrays longer than 128 in full (ros2 topic echo -f)
  --ros-args ...  ROS arguments (remappings, namespace, log level)

Exit codes:
  0  --once/--count messages arrived; SIGINT or SIGTERM; --timeout after at least one message
  1  no publisher on TOPIC within --timeout; its type is ambiguous or cannot be imported;
     --timeout ran out with no message
  2  bad options or ROS arguments (--count a whole number >= 1, --timeout finite > 0, no
     argument over 4096 characters); invalid topic name
Errors are one line on stderr, what was given cut to a few dozen characters. After SIGINT or
SIGTERM further signals are ignored while the echo cleans up and exits.
"""
from __future__ import annotations

import argparse
import importlib
import math
import os
import signal
import sys
import threading
import time
from typing import Any

from uav_insar_planner.ros.tools.msg_yaml import TRUNCATE_LENGTH, message_to_yaml

PROG = "uav-insar echo"


class CommandFailed(Exception):
    """A one-line error `str(self)` ending a command (echo, record) with exit code `code`."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.code = code


ERROR_LINE_MAX_CHARS = 300  # what the user typed is quoted in errors: a 100 kB name is cut
SHOWN_CHARS = 40
ARG_MAX_CHARS = 4096  # topic names and ROS arguments are far shorter


def _cut(text: str, limit: int = ERROR_LINE_MAX_CHARS) -> str:
    text = " ".join(text.split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2
        self.exit(2, _cut(f"{self.prog}: error: {message}") + "\n")


def _positive(kind: type) -> Any:
    """argparse type: a positive, finite int or float (`--count -1`, `--timeout inf` refused)."""
    def parse(text: str) -> Any:
        try:
            value = kind(text) if len(text) <= 30 else 0
        except ValueError:
            value = 0
        if not (value > 0 and math.isfinite(value)):
            raise argparse.ArgumentTypeError(
                f"expected a positive{' whole' if kind is int else ', finite'} number, got "
                f"{_cut(repr(text), SHOWN_CHARS)}")
        return value
    parse.__name__ = kind.__name__
    return parse


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Print a ROS 2 topic as `ros2 topic echo` does.",
                epilog="ROS arguments go after --ros-args. Exit codes: 0 done or interrupted, "
                "1 no publisher / unimportable type / no message within --timeout, 2 bad usage.")
    p.add_argument("topic", help="topic name, e.g. /formation (relative names get the namespace)")
    n = p.add_mutually_exclusive_group()
    n.add_argument("--once", action="store_true", help="exit after the first message")
    n.add_argument("--count", type=_positive(int), metavar="N", help="exit after N messages")
    p.add_argument("--timeout", type=_positive(float), metavar="S",
                   help="give up S seconds after start")
    p.add_argument("--full-length", action="store_true",
                   help=f"do not truncate strings and arrays after {TRUNCATE_LENGTH} items")
    return p


def _first_line(exc: BaseException) -> str:
    return str(exc).strip().splitlines()[0].rstrip(":") if str(exc).strip() else repr(exc)


def _interrupt(signum: int, frame: Any) -> None:
    # One signal ends the echo; more during the clean-up (or Python's exit) must not cut it
    # short, so from now on they are ignored.
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """Run `uav-insar echo` with `argv` (default sys.argv[1:]); returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    previous = {}  # SIGINT too, in case it came in ignored
    if threading.current_thread() is threading.main_thread():
        previous = {s: signal.signal(s, _interrupt) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        return _echo(argv)
    except CommandFailed as exc:
        print(_cut(f"{PROG}: error: {exc}"), file=sys.stderr)
        return exc.code
    except KeyboardInterrupt:
        previous = {}  # stay deaf to signals while Python exits (see _interrupt)
        return 0
    except BrokenPipeError:  # e.g. `| head`: stop quietly, and keep Python's exit flush quiet
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _echo(argv: list[str]) -> int:
    import rclpy
    from rclpy.exceptions import InvalidTopicNameException, NameValidationException
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from rclpy.signals import SignalHandlerOptions
    from rclpy.utilities import remove_ros_args
    from rclpy.validate_full_topic_name import validate_full_topic_name
    from rclpy.validate_topic_name import validate_topic_name

    for i, arg in enumerate(argv, 1):  # before rcl, which would log all of it or raise
        if len(arg) > ARG_MAX_CHARS:
            raise CommandFailed(f"argument {i} ({_cut(repr(arg), SHOWN_CHARS)}) is {len(arg)} "
                                f"characters long; expected at most {ARG_MAX_CHARS}", 2)
        try:
            arg.encode("utf-8")
        except UnicodeEncodeError:
            raise CommandFailed(f"argument {i} ({_cut(repr(arg), SHOWN_CHARS)}) is not UTF-8 "
                                "text", 2) from None
    try:
        plain = remove_ros_args([PROG, *argv])[1:]
    except (_rclpy.RCLError, _rclpy.UnknownROSArgsError) as exc:
        raise CommandFailed(f"bad ROS arguments: {_first_line(exc)}", 2) from None
    args = _parser().parse_args(plain)
    try:
        validate_topic_name(args.topic)
    except InvalidTopicNameException as exc:
        raise CommandFailed(_first_line(exc), 2) from None
    end = None if args.timeout is None else time.monotonic() + args.timeout
    want = 1 if args.once else args.count
    context = rclpy.Context()
    try:
        rclpy.init(args=[PROG, *argv], context=context,
                   signal_handler_options=SignalHandlerOptions.NO)
    except _rclpy.RCLError as exc:
        raise CommandFailed(f"bad ROS arguments: {_first_line(exc)}", 2) from None
    node = executor = None
    try:
        try:
            node = rclpy.create_node(f"_uav_insar_echo_{os.getpid()}", context=context,
                                     start_parameter_services=False, enable_rosout=False)
        except (_rclpy.RCLError, NameValidationException) as exc:
            raise CommandFailed(f"bad ROS arguments: {_first_line(exc)}", 2) from None
        try:
            topic = node.resolve_topic_name(args.topic)
            validate_full_topic_name(topic)
        except (_rclpy.RCLError, InvalidTopicNameException) as exc:
            raise CommandFailed(_first_line(exc), 2) from None
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
            raise CommandFailed(f"no message on {topic} within {args.timeout:g} s", 1)
        return 0
    except ExternalShutdownException:
        return 0
    finally:
        if executor is not None:
            executor.shutdown(timeout_sec=0)
        if node is not None:
            node.destroy_node()
        context.try_shutdown()


def _wait_for_publishers(node: Any, topic: str, end: float | None,
                         timeout: float | None) -> tuple[type, Any]:
    """The message class on `topic` and a QoS profile matching its publishers, once it has any."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    while True:
        infos = [i for i in node.get_publishers_info_by_topic(topic)  # not our own publishers
                 if (i.node_name, i.node_namespace) != (node.get_name(), node.get_namespace())]
        types = dict(node.get_topic_names_and_types()).get(topic)
        if infos and types:
            break
        if end is not None and time.monotonic() >= end:
            raise CommandFailed(f"no publisher on {topic} within {timeout:g} s", 1)
        time.sleep(0.05)
    if len(types) > 1:
        raise CommandFailed(f"{topic} has more than one type: {', '.join(types)}", 1)
    reliable = all(i.qos_profile.reliability == ReliabilityPolicy.RELIABLE for i in infos)
    latched = all(i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos)
    qos = QoSProfile(
        depth=10,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
    return message_class(types[0], topic), qos


def message_class(type_name: str, topic: str) -> type:
    """The Python class of ROS type `pkg/msg/Name`."""
    try:
        package, kind, name = type_name.split("/")
        cls = getattr(importlib.import_module(f"{package}.{kind}"), name)
        if not hasattr(cls, "get_fields_and_field_types"):
            raise TypeError("not a message class")
    except (ValueError, ImportError, AttributeError, TypeError) as exc:
        raise CommandFailed(f"cannot import message type {type_name} of {topic}: "
                    f"{_first_line(exc)}", 1) from None
    return cls


if __name__ == "__main__":
    raise SystemExit(main())
