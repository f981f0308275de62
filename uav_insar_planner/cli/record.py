"""`uav-insar record OUT`: record the suite's topics into a rosbag2 MCAP bag, on rclpy.

    uav-insar record OUT [--topics T [T ...]] [--duration S] [--ros-args ...]

Records every topic with a publisher (but /rosout, /parameter_events and hidden ones), or only
the --topics, each with its publishers' QoS, so latched topics such as /formation are recorded
and latch again on `ros2 bag play` (ros/tools/bag_recorder.py does the ROS work). It runs until
SIGINT / SIGTERM or --duration seconds, then closes the bag and prints one line:
`recorded N messages on M topics to OUT`. Exit codes (exit_codes.py): EXIT_OK when recorded
(even no message); EXIT_BAD_INPUT, one line on stderr and no bag, for OUT existing (a bag is
never overwritten), a bad topic name or duration, bad ROS arguments or params files in them.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_OK, CommandFailed

HELP = "record the topics into a rosbag2 MCAP bag"
ROS_ARGS = True  # the dispatcher hands what follows --ros-args to rcl, as args.ros_args


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = (f"ROS arguments go after --ros-args. Exit codes: {EXIT_OK} recorded, "
                     f"{EXIT_BAD_INPUT} bad usage.")
    parser.add_argument("out", type=Path, help="bag folder to create (must not exist)")
    parser.add_argument("--topics", nargs="+", metavar="T",
                        help="record only these topics (default: every topic but /rosout and "
                        "/parameter_events)")
    parser.add_argument("--duration", type=float, metavar="S",
                        help="stop after S seconds (default: at SIGINT / SIGTERM)")


def main(args: argparse.Namespace) -> int:
    if args.duration is not None and not args.duration > 0:
        raise CommandFailed(f"--duration: value {args.duration!r} is not allowed; expected > 0 s",
                            EXIT_BAD_INPUT)
    if args.out.exists():
        raise CommandFailed(f"OUT: {str(args.out)[:200]!r} exists; expected a new folder (a bag "
                            "is never overwritten)", EXIT_BAD_INPUT)
    from uav_insar_planner.ros.tools.bag_recorder import record

    return record(args)
