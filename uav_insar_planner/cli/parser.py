"""The one argument parser of every command of the suite: errors are one line, exit 2.

argparse quotes what it was given in its messages; a line is cut to ERROR_LINE_MAX_CHARS so a
100 kB argument cannot flood the terminal.
"""
from __future__ import annotations

import argparse
import re
from collections.abc import Sequence
from typing import Any

from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, CommandFailed

ERROR_LINE_MAX_CHARS = 300
SHOWN_CHARS = 40  # what the user typed, quoted in an error about it
ARG_MAX_CHARS = 4096  # per argument handed to rcl: topic names and ROS arguments are far shorter
ROS_ARGS, ROS_ARGS_END = "--ros-args", "--"
# A value that starts with a minus and a digit: `-27,47,-35,48` or `-1e3`. argparse takes such
# a word for an option unless it is one plain negative number; no option of the suite looks so.
_NEGATIVE_VALUE = re.compile(r"-\.?\d")


def one_line(text: str, limit: int = ERROR_LINE_MAX_CHARS) -> str:
    """`text` on one line (whitespace runs become one space), cut to `limit` characters."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _quoted(text: str) -> str:
    return one_line(repr(text), SHOWN_CHARS)


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line `PROG: error: ...` and exit code 2, and an
    option taking one value takes `-27,47,...` (a word starting with minus and a digit) as it,
    as it takes `-27`."""

    def error(self, message: str) -> None:
        self.exit(EXIT_BAD_INPUT, one_line(f"{self.prog}: error: {message}") + "\n")

    def parse_known_args(self, args: Sequence[str] | None = None,
                         namespace: argparse.Namespace | None = None) -> tuple[Any, list[str]]:
        if args is not None:
            args = self._join_negative_values(list(args))
        return super().parse_known_args(args, namespace)

    def _join_negative_values(self, args: list[str]) -> list[str]:
        takes_one = {s for a in self._actions if a.nargs is None for s in a.option_strings}
        joined: list[str] = []
        i = 0
        while i < len(args):
            if args[i] == "--":  # the rest are positional, as argparse has it
                return joined + args[i:]
            if (args[i] in takes_one and i + 1 < len(args)
                    and _NEGATIVE_VALUE.match(args[i + 1])):
                joined.append(f"{args[i]}={args[i + 1]}")
                i += 2
            else:
                joined.append(args[i])
                i += 1
        return joined


def split_ros_args(argv: Sequence[str]) -> tuple[list[str], list[str]]:
    """(the command's own arguments, the ROS arguments) of `argv`, by rcl's rule: ROS arguments
    run from each `--ros-args` to the next lone `--` or the end (the markers stay with them, for
    rclpy.init). Every argument goes to rcl, which logs or raises on all of it: CommandFailed
    (exit 2) for one over ARG_MAX_CHARS characters or not UTF-8 text, before anything runs."""
    for i, arg in enumerate(argv, 1):
        if len(arg) > ARG_MAX_CHARS:
            raise CommandFailed(f"argument {i} ({_quoted(arg)}) is {len(arg)} characters long; "
                                f"expected at most {ARG_MAX_CHARS}", EXIT_BAD_INPUT)
        try:
            arg.encode("utf-8")
        except UnicodeEncodeError:
            raise CommandFailed(f"argument {i} ({_quoted(arg)}) is not UTF-8 text",
                                EXIT_BAD_INPUT) from None
    own: list[str] = []
    ros: list[str] = []
    inside = False
    for arg in argv:
        if arg == ROS_ARGS:
            inside = True
            ros.append(arg)
        elif inside and arg == ROS_ARGS_END:
            inside = False
            ros.append(arg)
        else:
            (ros if inside else own).append(arg)
    return own, ros
