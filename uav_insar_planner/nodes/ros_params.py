"""ROS parameters declared from `params.PARAM_SPECS`, shared by the planner and agent nodes.

Every spec becomes one ROS parameter whose default is the Table I value, whose descriptor
carries the spec's description and (for numbers with both bounds, or a lower bound) a
FloatingPointRange / IntegerRange. The descriptor can only express closed ranges; open bounds,
list elements, choices and cross-field rules are enforced by `params.params_from_mapping`, so a
node always validates the full mapping through it before using any value.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from uav_insar_planner.params import ParamSpec
from uav_insar_planner.seam import (
    FloatingPointRange,
    IntegerRange,
    Node,
    ParameterDescriptor,
)


def spec_range(spec: ParamSpec) -> tuple[float, float] | None:
    """The closed range a descriptor can carry for a scalar numeric spec, else None.

    A missing upper bound becomes +inf (rclpy compares with min/max, so inf is harmless); a
    missing lower bound with an upper one becomes -inf. Lists and strings get no range.
    """
    if spec.kind is str or spec.length or (spec.lo is None and spec.hi is None):
        return None
    lo = -math.inf if spec.lo is None else float(spec.lo)
    hi = math.inf if spec.hi is None else float(spec.hi)
    return lo, hi


def descriptor_for(spec: ParamSpec) -> Any:
    """A ParameterDescriptor for `spec`: description with the allowed values, range if any."""
    desc = ParameterDescriptor(description=f"{spec.description}; {spec.allowed()}",
                               read_only=False)
    rng = spec_range(spec)
    if rng is not None and spec.kind is int:
        # IntegerRange fields are int64: an unbounded side is clamped to the int64 limit.
        lo = -(2**63) if math.isinf(rng[0]) else int(rng[0])
        hi = 2**63 - 1 if math.isinf(rng[1]) else int(rng[1])
        desc.integer_range = [IntegerRange(from_value=lo, to_value=hi, step=1)]
    elif rng is not None:
        desc.floating_point_range = [FloatingPointRange(from_value=rng[0], to_value=rng[1],
                                                        step=0.0)]
    return desc


def declare_specs(node: Node, specs: Iterable[ParamSpec]) -> list[str]:
    """Declare each spec on `node` (overrides from --ros-args apply); return problem lines.

    rclpy raises while declaring when an override has the wrong type or is outside the
    descriptor's range; such a parameter is declared with its default instead and one line
    naming it and what is allowed is returned, so the caller can report every problem at once.
    """
    problems = []
    for spec in specs:
        try:
            node.declare_parameter(spec.name, spec.default, descriptor_for(spec))
        except Exception as exc:  # rclpy's InvalidParameter*Exception have no common base
            if hasattr(exc, "value"):  # a value outside the range: say it as params.py does
                problems.append(f"{spec.name}: value {exc.value!r} is not allowed; expected "
                                f"{spec.allowed()}")
            else:  # wrong type (e.g. 4 for a double): the runtime's own words name it
                reason = " ".join(str(exc).split())
                problems.append(f"{spec.name}: {reason}; expected {spec.allowed()}")
            node.declare_parameter(spec.name, spec.default, descriptor_for(spec),
                                   ignore_override=True)
    return problems


def check_scalars(values: Mapping[str, Any], specs: Iterable[ParamSpec]) -> list[str]:
    """Problem lines for scalar numeric specs outside their (possibly open) bounds.

    For a node's own parameters that are not in PARAM_SPECS (params_from_mapping checks those).
    """
    problems = []
    for spec in specs:
        value = values[spec.name]
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(
            value) and (spec.kind is not int or float(value).is_integer())
        if ok and spec.lo is not None:
            ok = value > spec.lo if spec.lo_open else value >= spec.lo
        if ok and spec.hi is not None:
            ok = value <= spec.hi
        if not ok:
            problems.append(f"{spec.name}: value {value!r} is not allowed; expected "
                            f"{spec.allowed()}")
    return problems


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
