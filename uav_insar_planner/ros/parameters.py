"""The ROS parameters of every node of the suite, and how a node declares and guards them.

The tables are plain data in `param_specs/` (NODE_SPECS says which node takes which): the
planner's are PARAM_SPECS (Table I, all settable at run time) and PLANNER_SPECS (its own, not
the scenario's: uav_timeout_s, settable at run time); the agent's are AGENT_SPECS,
MAVLINK_SPECS and the scenario subset AGENT_SCENARIO_SPECS; the bridge's are BRIDGE_SPECS.
Agent and bridge parameters are read-only: they shape a mission or a MAVLink link that is set
up once, so a run-time set is refused, never taken and ignored.

Each parameter is declared with a descriptor: the description with what is allowed, the closed
range where the spec has one, and read_only. rclpy checks type, range and read_only; the rest
(open bounds, list lengths, choices, cross-field rules) is checked by the node's own validation.

An integer given for a double parameter (`speed_mps: 4` in a params file, `ros2 param set
/planner h_amb_min_m 1`) is taken as the double meant, at declaration and at run time (a
pre-set callback); a non-integral value for an integer parameter stays an error.

Names that no node knows are errors: `unknown_overrides` lists every override (params file or
`-p`) that names no parameter of any node of the suite, in `params.unknown_parameter`'s words,
the line `uav-insar solve --set` and `--params` give for the same name.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node
from rclpy.parameter import Parameter

from uav_insar_planner.param_specs.nodes import SUITE_PARAMETER_NAMES
from uav_insar_planner.params import ParamSpec, check_value, shown, unknown_parameter


def descriptor_for(spec: ParamSpec, read_only: bool) -> ParameterDescriptor:
    """A ParameterDescriptor for `spec`: description with the allowed values, closed range."""
    desc = ParameterDescriptor(description=f"{spec.description}; {spec.allowed()}",
                               read_only=read_only)
    if spec.kind not in (int, float) or spec.length or (spec.lo is None and spec.hi is None):
        return desc
    lo = -math.inf if spec.lo is None else spec.lo
    hi = math.inf if spec.hi is None else spec.hi
    if spec.kind is int:  # int64 fields: an open side is clamped to the int64 limit
        desc.integer_range = [IntegerRange(
            from_value=-(2**63) if math.isinf(lo) else int(lo),
            to_value=2**63 - 1 if math.isinf(hi) else int(hi), step=1)]
    else:
        desc.floating_point_range = [FloatingPointRange(from_value=float(lo),
                                                        to_value=float(hi), step=0.0)]
    return desc


def as_double(value: Any) -> Any:
    """An integer (or list of integers) as the double(s) meant; None for anything else."""
    if isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, (list, tuple)) and value and all(
            isinstance(v, int) and not isinstance(v, bool) for v in value):
        return [float(v) for v in value]
    return None


def _override(node: Node, name: str) -> Any:
    # rclpy has no public accessor for a node's overrides (params files and -p); read the
    # value it failed to declare, to take an integer as a double or to quote it in the error.
    param = node._parameter_overrides.get(name)  # noqa: SLF001
    return None if param is None else param.value


def declare_specs(node: Node, specs: Iterable[ParamSpec], read_only: bool = False) -> list[str]:
    """Declare each spec on `node` (overrides apply); return one problem line per bad value.

    A parameter whose override rclpy refuses, or an empty list (which rcl gives no type), is
    declared with its default instead, so every problem is reported at once and the caller
    stops before publishing anything.
    """
    problems = []
    for spec in specs:
        desc = descriptor_for(spec, read_only)
        given = node._parameter_overrides.get(spec.name)  # noqa: SLF001 - see _override
        if given is not None and given.type_ == Parameter.Type.NOT_SET:
            # rcl gives an empty list (`-p name:=[]`, `name: []`) no type: rclpy would
            # declare the parameter uninitialised, and reading it would raise.
            problems.append(f"{spec.name}: value [] is not allowed (an empty list); expected "
                            f"{spec.allowed()}")
            node.declare_parameter(spec.name, spec.default, desc, ignore_override=True)
            continue
        try:
            node.declare_parameter(spec.name, spec.default, desc)
            continue
        except InvalidParameterTypeException:
            value = _override(node, spec.name)
            double = as_double(value) if spec.kind is float else None
            if double is not None:
                try:
                    node.declare_parameter(spec.name, double, desc, ignore_override=True)
                    continue
                except InvalidParameterValueException:
                    pass
        except InvalidParameterValueException:
            value = _override(node, spec.name)
        problems.append(f"{spec.name}: value {shown(value)} is not allowed; expected "
                        f"{spec.allowed()}")
        node.declare_parameter(spec.name, spec.default, desc, ignore_override=True)
    return problems


def unknown_overrides(node: Node) -> list[str]:
    """One line per override that names a parameter of no node of the suite; a name another
    node takes is left to it (a `/**` section or `-p` serves every node)."""
    return [unknown_parameter(name)
            for name in sorted(node._parameter_overrides)  # noqa: SLF001 - see _override
            if not node.has_parameter(name) and name not in SUITE_PARAMETER_NAMES]


def guard_sets(node: Node) -> None:
    """Register the pre-set callback: integers for doubles become doubles; a refused
    read-only set is logged with the parameter, the value and why."""

    def pre_set(parameters: list[Parameter]) -> list[Parameter]:
        out = []
        for p in parameters:
            if not node.has_parameter(p.name):
                out.append(p)
                continue
            desc = node.describe_parameter(p.name)
            if desc.read_only:
                node.get_logger().warning(
                    f"{p.name}: value {shown(p.value)} refused: read-only, set at start-up "
                    f"only (--ros-args -p {p.name}:=...)")
            double = as_double(p.value)
            if double is not None and desc.type in (Parameter.Type.DOUBLE.value,
                                                    Parameter.Type.DOUBLE_ARRAY.value):
                p = Parameter(p.name, value=double)
            out.append(p)
        return out

    node.add_pre_set_parameters_callback(pre_set)


def plain_value(value: Any) -> Any:
    """A parameter value as params.py expects it: arrays (rclpy may hand array.array) as lists."""
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        return value
    return list(value)


def spec_values(node: Node, specs: Iterable[ParamSpec],
                changes: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The node's current values of `specs` (file units), with pending `changes` on top."""
    values = {s.name: plain_value(node.get_parameter(s.name).value) for s in specs}
    for name, value in (changes or {}).items():
        if name in values:
            values[name] = plain_value(value)
    return values


def check_values(values: Mapping[str, Any], specs: Iterable[ParamSpec]) -> list[str]:
    """Problem lines for a node's own parameters (params.check_value on each)."""
    return [problem for spec in specs
            if (problem := check_value(spec, values[spec.name])[1]) is not None]

