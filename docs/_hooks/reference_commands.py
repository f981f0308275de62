"""The commands page: the `--help` of every command of the suite, from its own parser, and the
node executables with their ROS arguments, parameters and topics."""
from __future__ import annotations

import argparse
import functools
import importlib
import inspect

import reference_md as md
from reference_parameters import GROUPS, anchors
from reference_topics import shown_name, topic_anchor

from uav_insar_planner.cli import PROG, build_parser, verbs
from uav_insar_planner.demo.options import build_parser as demo_parser
from uav_insar_planner.demo.processes import MODULES
from uav_insar_planner.param_specs.nodes import NODE_SPECS
from uav_insar_planner.ros.topics import INTERFACE

#: Columns of every help text: fixed, so the page does not depend on the terminal it was
#: built in.
HELP_WIDTH = 100
DEMO = "python -m uav_insar_planner.demo"
# rcl parses these (rclpy.init); the nodes take nothing else.
NODE_USAGE = ("{name} [--ros-args [-p NAME:=VALUE]... [--params-file FILE] [-r __node:=NAME] "
              "[-r __ns:=/NAMESPACE] [--log-level LEVEL] [--]]")


def help_text(parser: argparse.ArgumentParser) -> str:
    """`parser`'s --help, HELP_WIDTH columns wide."""
    parser.formatter_class = functools.partial(parser.formatter_class, width=HELP_WIDTH)
    return parser.format_help()


def vehicle_parser() -> argparse.ArgumentParser:
    """`uav-insar-vehicle`'s parser (the simulator is a tool of the suite, imported only here)."""
    from uav_insar_sim.vehicle.cli import build_parser as build

    return build()


def _help_section(level: str, title: str, parser: argparse.ArgumentParser) -> list[str]:
    return [f"{level} `{title}`", "", "```text", help_text(parser).rstrip(), "```", ""]


def _node_parameters(name: str) -> list[str]:
    where = anchors()
    lines = []
    for group in GROUPS:
        taken = [s for s in NODE_SPECS[name] if any(s is g for g in group.specs)]
        if taken:
            links = ", ".join(f"[`{s.name}`](parameters.md#{where[id(s)]})" for s in taken)
            lines.append(f"- {group.title}: {links}")
    return lines


def _node_topics(name: str, role: str) -> str:
    found = [s for s in INTERFACE if name in getattr(s, role) and not s.is_service]
    return ", ".join(f"[`{shown_name(s)}`](topics.md#{topic_anchor(s)})" for s in found) or "-"


def _node_section(name: str) -> list[str]:
    doc = inspect.getdoc(importlib.import_module(MODULES[name])) or ""
    services = [s for s in INTERFACE if s.is_service and name in s.publishers]
    lines = [f"### `{name}`", "", md.text(doc.split("\n\n")[0]), "", "```text",
             NODE_USAGE.format(name=name), "```", "",
             f"As `ros2 run uav_insar_planner {name} --ros-args ...` on a sourced Jazzy. "
             "Parameters it declares:", ""]
    lines += _node_parameters(name)
    lines += ["", f"Publishes {_node_topics(name, 'publishers')}; subscribes "
              f"{_node_topics(name, 'subscribers')}"
              + "".join(f"; serves [`{shown_name(s)}`](topics.md#{topic_anchor(s)})"
                        for s in services) + ".", ""]
    return lines


def commands_page() -> str:
    """The Markdown of reference/commands.md."""
    table = verbs()
    top, verb_parsers = build_parser(table)
    lines = ["# Commands", "",
             md.generated_from("uav_insar_planner/cli/", "uav_insar_planner/demo/options.py",
                               "uav_insar_sim/vehicle/cli.py",
                               "uav_insar_planner/param_specs/"), "",
             f"Every command's `--help`, {HELP_WIDTH} columns wide. Every command and node ends "
             "with a code of [one table](exit-codes.md).", "",
             f"## `{PROG}`", "", "```text", help_text(top).rstrip(), "```", ""]
    for name, parser in verb_parsers.items():
        lines += _help_section("###", f"{PROG} {name}", parser)
    lines += ["## The demo", "", "`make demo` runs it with its defaults.", ""]
    lines += _help_section("###", DEMO, demo_parser())
    lines += ["## The vehicle simulator", ""]
    lines += _help_section("###", "uav-insar-vehicle", vehicle_parser())
    lines += ["## Nodes", "",
              "The node executables take no options of their own: only ROS arguments after "
              "`--ros-args`, which rcl parses. A bad parameter (a value outside what is "
              "allowed, a name no node of the suite knows) stops the node at start with one "
              "line per problem and exit code 2.", ""]
    for name in NODE_SPECS:
        lines += _node_section(name)
    return "\n".join(lines).rstrip() + "\n"
