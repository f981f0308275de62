"""The ROS parameters of every node of the suite, and how a node declares and guards them.

Tables: the planner's are `params.PARAM_SPECS` (Table I, all settable at run time); the
agent's are AGENT_SPECS, MAVLINK_SPECS and the scenario subset AGENT_SCENARIO_NAMES; the
bridge's are BRIDGE_SPECS. Agent and bridge parameters are read-only: they shape a mission or
a MAVLink link that is set up once, so a run-time set is refused, never taken and ignored.

Each parameter is declared with a descriptor: the description with what is allowed, the closed
range where the spec has one, and read_only. rclpy checks type, range and read_only; the rest
(open bounds, list lengths, choices, cross-field rules) is checked by the node's own validation.

An integer given for a double parameter (`speed_mps: 4` in a params file, `ros2 param set
/planner h_amb_min_m 1`) is taken as the double meant, at declaration and at run time (a
pre-set callback); a non-integral value for an integer parameter stays an error.

Names that no node knows are errors: `unknown_overrides` lists every override (params file or
`-p`) that names no parameter of any node of the suite, with "did you mean" where one is close.
"""
from __future__ import annotations

import difflib
import math
from collections.abc import Iterable, Mapping
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node
from rclpy.parameter import Parameter

from uav_insar_planner.params import PARAM_SPECS, SPEC_BY_NAME, ParamSpec

AGENT_SPECS = (
    ParamSpec("uav_id", int, 0, "which UAV this agent flies: 0 master, 1, 2", 0, 2),
    ParamSpec("time_scale", float, 1.0, "mission seconds per wall-clock second", 0.0, 1000.0,
              True),
    ParamSpec("position_noise_std_m", float, 0.0, "std of the position disturbance per axis "
              "[m]", 0.0, 100.0),
    ParamSpec("noise_seed", int, 0, "seed of the position disturbance", 0, 2**31 - 1),
    ParamSpec("max_speed_mps", float, 10.0, "speed limit [m/s], at least speed_mps", 0.0,
              100.0, True),
    ParamSpec("max_accel_mps2", float, 3.0, "acceleration limit [m/s^2]", 0.0, 50.0, True),
)
MAVLINK_SPECS = (
    ParamSpec("mavlink_listen", str, "", "MAVLink mode: the embedded vehicle's connection "
              "string, e.g. udpin:127.0.0.1:14552 (empty: fly /formation directly)"),
    ParamSpec("mavlink_sysid", int, 0, "MAVLink mode: the embedded vehicle's sysid (0: 2 + "
              "uav_id)", 0, 255),
    ParamSpec("track_bearing_deg", float, 0.0, "MAVLink mode: bearing of the along-track "
              "axis from north [deg], as the bridge's", -360.0, 360.0),
    ParamSpec("origin_ned_m", float, [0.0, 0.0, 0.0], "MAVLink mode: track origin in the "
              "vehicle's local NED [m], as the bridge's", length=3),
)
AGENT_SCENARIO_NAMES = ("num_slots", "slot_duration_s", "speed_mps", "ground_station_m",
                        "comm_bandwidth_hz", "ref_snr_db", "rate_min_mbps")

# The bridge's full rules live in BridgeConfig.validate; these carry the descriptors. Defaults
# pair with `uav-insar-vehicle --sysid 2..4 --listen udpin:127.0.0.1:14552/14562/14572`.
BRIDGE_SPECS = (
    ParamSpec("connections", list, ["udpout:127.0.0.1:14552", "udpout:127.0.0.1:14562",
                                    "udpout:127.0.0.1:14572"],
              "pymavlink connection string per UAV (or one shared): udpout:HOST:PORT, "
              "udpin:HOST:PORT, tcp:HOST:PORT, /dev/ttyUSB0,57600"),
    ParamSpec("target_sysids", list, [2, 3, 4], "MAVLink system id of UAV 0, 1, 2 (1..255, "
              "distinct)"),
    ParamSpec("source_sysid", int, 255, "our own system id (ArduPilot: match SYSID_MYGCS)",
              1, 255),
    ParamSpec("track_bearing_deg", float, 0.0, "bearing of the along-track axis y from north "
              "[deg]", -360.0, 360.0),
    ParamSpec("origin_ned_m", float, [0.0, 0.0, 0.0], "track origin in local NED (N, E, D) [m]",
              length=3),
    ParamSpec("setpoint_rate_hz", float, 10.0, "SET_POSITION_TARGET_LOCAL_NED rate per UAV "
              "[Hz]", 2.0, 50.0),
    ParamSpec("velocity_feedforward", bool, False, "send the along-track velocity too "
              "(type_mask 3520)"),
    ParamSpec("arm_and_takeoff", bool, False, "set GUIDED/OFFBOARD, arm and take off "
              "(default: you do)"),
    ParamSpec("autopilot", str, "ardupilot", "mode numbers and arming sequence",
              choices=("ardupilot", "px4")),
    ParamSpec("speed_mps", float, 4.3, "along-track speed v_y [m/s]", 0.0, 1000.0),
    ParamSpec("track_duration_s", float, 0.0, "length of the pass in time, then hold at its "
              "end; 0: no end [s]", 0.0, 1e6),
    ParamSpec("capture_radius_m", float, 1.0, "start the pass when every UAV is this close to "
              "its start point; 0: start at once [m]", 0.0, 1e4),
    ParamSpec("heartbeat_timeout_s", float, 5.0, "report a UAV lost after this long without "
              "heartbeat [s]", 0.0, 3600.0, True),
)

#: Every parameter name of every node of the suite (a shared `/**` section may hold any).
SUITE_PARAMETER_NAMES = frozenset(
    [s.name for s in PARAM_SPECS + AGENT_SPECS + MAVLINK_SPECS + BRIDGE_SPECS]
    + ["use_sim_time"])
VALUE_SHOWN_CHARS = 60


def shown(value: Any) -> str:
    """repr(value), cut to VALUE_SHOWN_CHARS for an error line."""
    text = repr(list(value) if isinstance(value, tuple) else value)
    return text if len(text) <= VALUE_SHOWN_CHARS else text[:VALUE_SHOWN_CHARS - 3] + "..."


def allowed(spec: ParamSpec) -> str:
    """What `spec` allows, in words (params.ParamSpec.allowed, plus bool and lists)."""
    if spec.kind is bool:
        return "true or false"
    if spec.kind is list:
        return "a list of " + ("strings" if isinstance(spec.default[0], str) else "integers")
    return spec.allowed()


def descriptor_for(spec: ParamSpec, read_only: bool) -> ParameterDescriptor:
    """A ParameterDescriptor for `spec`: description with the allowed values, closed range."""
    desc = ParameterDescriptor(description=f"{spec.description}; {allowed(spec)}",
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

    A parameter whose override rclpy refuses is declared with its default instead, so every
    problem is reported at once and the caller stops before publishing anything.
    """
    problems = []
    for spec in specs:
        desc = descriptor_for(spec, read_only)
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
                        f"{allowed(spec)}")
        node.declare_parameter(spec.name, spec.default, desc, ignore_override=True)
    return problems


def unknown_overrides(node: Node) -> list[str]:
    """One line per override that names a parameter of no node of the suite."""
    problems = []
    for name in sorted(node._parameter_overrides):  # noqa: SLF001 - see _override
        if node.has_parameter(name) or name in SUITE_PARAMETER_NAMES:
            continue
        near = difflib.get_close_matches(name, SUITE_PARAMETER_NAMES, n=1)
        hint = f" (did you mean {near[0]}?)" if near else ""
        problems.append(f"{name}: no such parameter of {node.get_name()} or any node of "
                        f"uav_insar_planner{hint}")
    return problems


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


def check_scalars(values: Mapping[str, Any], specs: Iterable[ParamSpec]) -> list[str]:
    """Problem lines for scalar numeric specs outside their (possibly open) bounds; for a
    node's own parameters, which params_from_mapping does not know."""
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
            problems.append(f"{spec.name}: value {shown(value)} is not allowed; expected "
                            f"{allowed(spec)}")
    return problems


def agent_scenario_specs() -> tuple[ParamSpec, ...]:
    """The scenario parameters an agent needs, as PARAM_SPECS has them."""
    return tuple(SPEC_BY_NAME[n] for n in AGENT_SCENARIO_NAMES)
