"""The parameters page: every parameter of every node, from uav_insar_planner/param_specs/."""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from typing import Any

import reference_md as md

from uav_insar_planner.param_specs import ParamSpec
from uav_insar_planner.param_specs.nodes import (
    AGENT_SCENARIO_SPECS,
    AGENT_SPECS,
    BRIDGE_SPECS,
    MAVLINK_SPECS,
    NODE_SPECS,
    PLANNER_SPECS,
    RCLPY_PARAMETER_NAMES,
    nodes_taking,
)
from uav_insar_planner.param_specs.science import PARAM_SPECS
from uav_insar_planner.params_file import yaml_load

# param_specs writes a unit as ` [unit]` inside the description, once at most.
_UNIT = re.compile(r" \[([^\[\]]+)\]")
# Floats outside this range of magnitudes read better as config/params.yaml writes them: 1.0e9.
_PLAIN_FLOAT = (1e-3, 1e5)


@dataclass(frozen=True)
class Group:
    """One section of the page: `key` prefixes the anchors of names another group also has."""

    key: str
    title: str
    specs: tuple[ParamSpec, ...]
    intro: str


GROUPS = (
    Group("scenario", "Scenario (Table I)", PARAM_SPECS,
          "The scenario the planner solves (`PARAM_SPECS`), all settable at run time: a set "
          "is validated with the whole scenario and solved again. `config/params.yaml` holds "
          "these values, Table I of the paper, in a `/**` section every node reads; a default "
          "marked field-only departs from the paper's problem (P) for flying, and `--paper` "
          "(`load_params(paper=True)`) sets it back. The agents "
          "take the subset they fly by (`AGENT_SCENARIO_SPECS`: "
          + ", ".join(f"`{s.name}`" for s in AGENT_SCENARIO_SPECS) + ")."),
    Group("planner", "Planner only", PLANNER_SPECS,
          "The planner's own parameters beside the scenario (`PLANNER_SPECS`), settable at "
          "run time."),
    Group("agent", "Agent", AGENT_SPECS,
          "The simulated UAV's parameters (`AGENT_SPECS`), read-only: they shape a mission "
          "that is set up once."),
    Group("agent-mavlink", "Agent, MAVLink mode", MAVLINK_SPECS,
          "The agent with an embedded vehicle driven through MAVLink (`MAVLINK_SPECS`), "
          "read-only."),
    Group("bridge", "MAVLink bridge", BRIDGE_SPECS,
          "The `mavlink_bridge` node's parameters (`BRIDGE_SPECS`), read-only: the links are "
          "opened once."),
)


def yaml_value(value: Any) -> str:
    """`value` as a ROS 2 params file writes it (the suite's reader reads it back equal)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return _yaml_float(value)
    if isinstance(value, str):
        plain = value and yaml_load(f"v: {value}") == {"v": value}
        return value if plain else json.dumps(value)
    items = (json.dumps(v) if isinstance(v, str) else yaml_value(v) for v in value)
    return "[" + ", ".join(items) + "]"


def _yaml_float(value: float) -> str:
    if value == 0 or _PLAIN_FLOAT[0] <= abs(value) < _PLAIN_FLOAT[1]:
        return repr(value)
    mantissa, exponent = f"{value:.15e}".split("e")
    mantissa = mantissa.rstrip("0")
    written = f"{mantissa}0e{int(exponent)}" if mantissa.endswith(".") else \
        f"{mantissa}e{int(exponent)}"
    return written if float(written) == value else repr(value)


def ros_type(spec: ParamSpec) -> str:
    """The ROS parameter type `spec` is declared with."""
    if spec.kind is list:
        return ("string" if isinstance(spec.default[0], str) else "integer") + "[]"
    name = {bool: "bool", int: "integer", float: "double", str: "string"}[spec.kind]
    return f"{name}[{spec.length}]" if spec.length else name


def unit_and_description(spec: ParamSpec) -> tuple[str, str]:
    """(the unit, '' for none; the description without the unit and without `why`, which
    `_f` appends to it)."""
    desc = spec.description
    if spec.why and desc.endswith("; " + spec.why):
        desc = desc[:-len(spec.why) - 2]
    units = _UNIT.findall(desc)
    if len(units) > 1:
        raise ValueError(f"{spec.name}: more than one [unit] in its description: {units}")
    return (units[0], _UNIT.sub("", desc)) if units else ("", desc)


def anchors() -> dict[int, str]:
    """The anchor of each spec (by id): its name, or `GROUP-name` where an earlier group
    already has the name."""
    found: dict[int, str] = {}
    taken: set[str] = set()
    for group in GROUPS:
        for spec in group.specs:
            found[id(spec)] = spec.name if spec.name not in taken else f"{group.key}-{spec.name}"
            taken.add(spec.name)
    return found


def _row(group: Group, spec: ParamSpec, where: dict[int, str]) -> list[str]:
    unit, desc = unit_and_description(spec)
    allowed = md.text(spec.allowed()) + (f": {md.text(spec.why)}" if spec.why else "")
    nodes = ", ".join(f"[`{n}`](commands.md#{md.heading_id(n)})" for n in nodes_taking(spec.name))
    twins = [f"[{g.title}](#{where[id(s)]})" for g in GROUPS for s in g.specs
             if s.name == spec.name and s is not spec]
    also = (f". The same name in {', '.join(twins)}: a `/**` section sets each"
            if twins else "")
    if spec.paper is not None:  # a field-only default (param_specs.science.PAPER_VALUES)
        also += (f". Field-only default: the paper's problem has {yaml_value(spec.paper)}, "
                 "which `--paper` sets")
    return [f"{md.anchor(where[id(spec)])}`{spec.name}`", ros_type(spec),
            md.code(yaml_value(spec.default)), md.text(unit), allowed, nodes,
            md.text(desc) + also]


def parameters_page() -> str:
    """The Markdown of reference/parameters.md."""
    where = anchors()
    lines = ["# Parameters", "",
             md.generated_from("uav_insar_planner/param_specs/"), "",
             "Every ROS parameter of every node of the suite: its type, its default as a params "
             "file writes it, its unit, what is allowed and why the range stops there, and the "
             "nodes that take it. A value outside what is allowed stops a node at start (exit "
             "code 2, one line naming it) and is refused at run time. `config/params.yaml` holds "
             "Table I, the scenario's defaults. A name that more than one node declares is set "
             "for each of them by a `/**` section; link to a parameter as "
             "`reference/parameters.md#NAME` (`#GROUP-NAME` for the second node's entry of a "
             "shared name, e.g. `#bridge-uav_id`).", "",
             "rclpy declares " + " and ".join(f"`{n}`" for n in RCLPY_PARAMETER_NAMES)
             + " on every node itself."]
    for group in GROUPS:
        lines += ["", f"## {group.title}", "", group.intro, ""]
        lines += md.table(("Parameter", "Type", "Default", "Unit", "Allowed", "Nodes",
                           "Description"),
                          (_row(group, spec, where) for spec in group.specs))
    return "\n".join(lines) + "\n"


def every_spec() -> list[ParamSpec]:
    """Every spec any node declares (for the check that the page misses none)."""
    return [s for specs in NODE_SPECS.values() for s in specs]
