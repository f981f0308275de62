"""`uav-insar echo TOPIC`: print a topic's messages as `ros2 topic echo` does, on rclpy.

    uav-insar echo TOPIC [--once | --count N] [--timeout S] [--full-length] [--ros-args ...]

The echo waits for a publisher on TOPIC and matches its QoS, so a late echo gets latched topics
such as /formation (ros/tools/echo.py does the ROS work). Options:
  --once          exit after the first message (same as --count 1)
  --count N       exit after N messages (default: run until SIGINT or SIGTERM)
  --timeout S     give up S seconds after start (the wait for a publisher included)
  --full-length   print strings and arrays longer than 128 in full (ros2 topic echo -f)
  --ros-args ...  ROS arguments (remappings, namespace, log level)

Exit codes (exit_codes.py): EXIT_OK when the --once/--count messages arrived, at SIGINT or
SIGTERM, and at --timeout after at least one message; EXIT_CRASH when nothing came to echo (no
publisher on TOPIC within --timeout, no message within it, a type that is ambiguous or cannot
be imported); EXIT_BAD_INPUT for bad options or ROS arguments (--count a whole number >= 1,
--timeout finite > 0, no argument over parser.ARG_MAX_CHARS characters) and an invalid topic
name. Errors are one line on stderr, what was given cut to a few dozen characters.
"""
from __future__ import annotations

import argparse
import math
from collections.abc import Callable

from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_CRASH, EXIT_OK
from uav_insar_planner.params import shown
from uav_insar_planner.ros.tools.msg_yaml import TRUNCATE_LENGTH

HELP = "print a topic like `ros2 topic echo`"
LEAN = True  # rclpy and yaml only: it runs on a UAV's lean install (extras.py)
ROS_ARGS = True  # the dispatcher hands what follows --ros-args to rcl, as args.ros_args


def _positive(kind: type) -> Callable[[str], float]:
    """argparse type: a positive, finite int or float (`--count -1`, `--timeout inf` refused)."""
    def parse(text: str) -> float:
        try:
            value = kind(text) if len(text) <= 30 else 0
        except ValueError:
            value = 0
        if not (value > 0 and math.isfinite(value)):
            raise argparse.ArgumentTypeError(
                f"expected a positive{' whole' if kind is int else ', finite'} number, got "
                f"{shown(text)}")
        return value
    parse.__name__ = kind.__name__
    return parse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = (f"ROS arguments go after --ros-args. Exit codes: {EXIT_OK} done or "
                     f"interrupted, {EXIT_CRASH} no publisher / unimportable type / no message "
                     f"within --timeout, {EXIT_BAD_INPUT} bad usage.")
    parser.add_argument("topic",
                        help="topic name, e.g. /formation (relative names get the namespace)")
    n = parser.add_mutually_exclusive_group()
    n.add_argument("--once", action="store_true", help="exit after the first message")
    n.add_argument("--count", type=_positive(int), metavar="N", help="exit after N messages")
    parser.add_argument("--timeout", type=_positive(float), metavar="S",
                        help="give up S seconds after start")
    parser.add_argument("--full-length", action="store_true",
                        help=f"do not truncate strings and arrays after {TRUNCATE_LENGTH} items")


def main(args: argparse.Namespace) -> int:
    from uav_insar_planner.ros.tools.echo import echo

    return echo(args)
