"""The demo's check of every node's own parameters before any process starts.

Each node the demo would start gets the values a node of its name takes: the params file's
matching sections, then every `-p`, then what the demo sets itself. Each value is judged by
the node's specs (param_specs.nodes.NODE_SPECS, with `params.check_value`, the check the nodes make
at start-up), and the bridge's whole configuration by its own cross-field rules
(`mavlink.config`: gcs_timeout_s 0 or at least 1 s, ...), so a value a node would refuse is
one line and exit 2 here, not a swarm started and then stopped by one refusing node. The
scenario's values are the planner's, checked by `load_params`; the agent's cross-field rules
live in the simulator, which this package does not import: the agent checks them itself.
"""
from __future__ import annotations

import argparse
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from uav_insar_planner.param_specs import ParamSpec
from uav_insar_planner.param_specs.nodes import NODE_SPECS
from uav_insar_planner.param_specs.science import SPEC_BY_NAME
from uav_insar_planner.params import check_value, shown
from uav_insar_planner.swarm import uavs

if TYPE_CHECKING:
    from uav_insar_planner.params import Params

# A placeholder for the connections the demo wires itself (the vehicles' ports are chosen
# later): any valid address, so that the bridge's own rules judge the rest.
_WIRED = "udpout:127.0.0.1:14552"


def _value_problem(spec: ParamSpec, value: Any) -> str | None:
    if spec.kind is bool:
        return None if isinstance(value, bool) else (
            f"{spec.name}: value {shown(value)} is not allowed; expected {spec.allowed()}")
    if spec.kind is list:  # connections, target_sysids: the demo wires them itself
        return None
    return check_value(spec, value)[1]


def value_problems(node: str, values: Mapping[str, Any]) -> list[str]:
    """One line per value of `values` that node `node` takes and would refuse (the scenario's
    own are left to load_params)."""
    return [problem for spec in NODE_SPECS[node]
            if spec.name in values and spec.name not in SPEC_BY_NAME
            and (problem := _value_problem(spec, values[spec.name])) is not None]


def bridge_problem(values: Mapping[str, Any], flown: list[int], stacks: bool,
                   pass_s: float) -> str | None:
    """The bridge's own verdict (mavlink.config) on its values with the demo's wiring: one
    bridge flying the UAVs `flown`, or (`stacks`) the stack of the one UAV in `flown`."""
    from uav_insar_planner.mavlink.config import from_parameters
    from uav_insar_planner.param_specs.nodes import BRIDGE_SPECS, FIRST_SYSID

    given = {spec.name: values.get(spec.name, spec.default) for spec in BRIDGE_SPECS}
    given |= {"connections": [_WIRED], "target_sysids": [FIRST_SYSID + k for k in flown],
              "velocity_feedforward": True, "track_duration_s": float(pass_s)}
    if stacks:
        given["uav_id"] = flown[0]
    try:
        from_parameters(given).validate()
    except (TypeError, ValueError) as exc:
        return str(exc)
    return None


def node_problems(args: argparse.Namespace, overrides: Mapping[str, Any],
                  params: Params) -> list[str]:
    """Every problem (one line each, once) of the values the demo's nodes would get: the
    planner, the agents and, unless --no-mavlink, the bridge(s)."""
    from uav_insar_planner.demo.steps import node_names, pass_duration_s
    from uav_insar_planner.params_file import parse_params_file

    file = parse_params_file(args.params_file) if args.params_file else None
    swarm = list(uavs(params.num_uavs))
    problems: list[str] = []
    nodes = ("planner", "agent") + (() if args.no_mavlink else ("mavlink_bridge",))
    for node in nodes:
        for k, fqn in enumerate(node_names(node, args)[:len(swarm)]):
            values = {**(file.values_for(fqn) if file else {}), **overrides}
            found = value_problems(node, values)
            if node == "mavlink_bridge" and not found:
                flown = [k] if args.per_uav_stacks else swarm
                problem = bridge_problem(values, flown, args.per_uav_stacks,
                                         pass_duration_s(params))
                found = [] if problem is None else [problem]
            problems += found
    return list(dict.fromkeys(problems))
