"""The ROS parameters of every node of the suite, and how a node declares and guards them.

Tables: the planner's are `params.PARAM_SPECS` (Table I, all settable at run time) and
PLANNER_SPECS (its own, not the scenario's: uav_timeout_s, settable at run time); the
agent's are AGENT_SPECS, MAVLINK_SPECS and the scenario subset AGENT_SCENARIO_NAMES; the
bridge's are `mavlink.config.BRIDGE_SPECS`. Agent and bridge parameters are read-only: they
shape a mission or a MAVLink link that is set up once, so a run-time set is refused, never
taken and ignored.

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

from uav_insar_planner.mavlink.config import BRIDGE_SPECS, ORIGIN_LIMIT_M
from uav_insar_planner.params import PARAM_SPECS, SPEC_BY_NAME, ParamSpec, check_value, shown
from uav_insar_planner.swarm import NUM_UAVS

AGENT_SPECS = (
    ParamSpec("uav_id", int, 0, "which UAV this agent flies: 0 master, 1, 2", 0, NUM_UAVS - 1),
    ParamSpec("time_scale", float, 1.0, "mission seconds per wall-clock second", 0.0, 1000.0,
              True),
    ParamSpec("position_noise_std_m", float, 0.0, "std of the position disturbance per axis "
              "[m]", 0.0, 100.0),
    ParamSpec("noise_seed", int, 0, "seed of the position disturbance", 0, 2**31 - 1),
    ParamSpec("max_speed_mps", float, 10.0, "speed limit [m/s], at least speed_mps", 0.0,
              100.0, True),
    ParamSpec("max_accel_mps2", float, 3.0, "acceleration limit [m/s^2]", 0.0, 50.0, True),
    ParamSpec("offloading", str, "open", "power per slot: open = the plan's P_com[k][n], "
              "closed = least power meeting R_min from the measured rate and position",
              choices=("open", "closed")),
    ParamSpec("shadowing_std_db", float, 0.0, "simulated link: std of the log-normal "
              "shadowing [dB] (0: off)", 0.0, 30.0),
    ParamSpec("shadowing_corr_m", float, 20.0, "simulated link: correlation length of the "
              "shadowing along the track [m]", 0.0, 10000.0, True),
    ParamSpec("small_scale_fading", str, "off", "simulated link: small-scale fading, off or "
              "rician (K-factor rician_k_db)", choices=("off", "rician")),
    ParamSpec("rician_k_db", float, 10.0, "simulated link: Rician K-factor [dB], when "
              "small_scale_fading is rician", -30.0, 60.0),
    ParamSpec("fading_seed", int, 0, "seed of the simulated link fading and of the wind "
              "gusts", 0, 2**31 - 1),
    ParamSpec("wind_mps", float, [0.0, 0.0, 0.0], "steady wind (x, y, z) in the track frame "
              "[m/s], self-flown agent only", -50.0, 50.0, length=3),
    ParamSpec("gust_std_mps", float, 0.0, "std of the wind gusts per axis [m/s] (0: off)",
              0.0, 30.0),
    ParamSpec("gust_tau_s", float, 2.0, "time constant of the wind gusts [s]", 0.0, 1000.0,
              True),
)
MAVLINK_SPECS = (
    ParamSpec("mavlink_listen", str, "", "MAVLink mode: the embedded vehicle's connection "
              "string, e.g. udpin:127.0.0.1:14552 (empty: fly /formation directly)"),
    ParamSpec("mavlink_sysid", int, 0, "MAVLink mode: the embedded vehicle's sysid (0: 2 + "
              "uav_id)", 0, 255),
    ParamSpec("track_bearing_deg", float, 0.0, "MAVLink mode: bearing of the along-track "
              "axis from north [deg], as the bridge's", -360.0, 360.0),
    ParamSpec("origin_ned_m", float, [0.0, 0.0, 0.0], "MAVLink mode: track origin in the "
              f"vehicle's local NED, as the bridge's; within +-{ORIGIN_LIMIT_M:g} m [m]",
              -ORIGIN_LIMIT_M, ORIGIN_LIMIT_M, length=3),
)
#: The planner's own parameters beside the scenario's PARAM_SPECS; closed ranges, which rclpy
#: checks at start and on every set, so nothing else validates them.
PLANNER_SPECS = (
    ParamSpec("uav_timeout_s", float, 5.0, "a UAV heard once and then silent (no pose, rate "
              "or offload) this long [s] is lost: the swarm is re-planned without it", 0.1,
              3600.0),
)
AGENT_SCENARIO_NAMES = ("num_slots", "slot_duration_s", "speed_mps", "ground_station_m",
                        "comm_bandwidth_hz", "ref_snr_db", "rate_min_mbps", "p_com_max_db",
                        "e_com_max_j")

#: Every parameter name of every node of the suite (a shared `/**` section may hold any).
SUITE_PARAMETER_NAMES = frozenset(
    [s.name for s in PARAM_SPECS + PLANNER_SPECS + AGENT_SPECS + MAVLINK_SPECS + BRIDGE_SPECS]
    + ["use_sim_time"])
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


def check_values(values: Mapping[str, Any], specs: Iterable[ParamSpec]) -> list[str]:
    """Problem lines for a node's own parameters (params.check_value on each)."""
    return [problem for spec in specs
            if (problem := check_value(spec, values[spec.name])[1]) is not None]


def agent_scenario_specs() -> tuple[ParamSpec, ...]:
    """The scenario parameters an agent needs, as PARAM_SPECS has them."""
    return tuple(SPEC_BY_NAME[n] for n in AGENT_SCENARIO_NAMES)
