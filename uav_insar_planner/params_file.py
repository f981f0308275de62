"""Params files and overrides: ROS 2 params YAML and `NAME=VALUE` text to a validated Params.

The one params-file reader of the suite: `uav-insar solve/sweep/report --params`, the demo's
`--params-file` and every node's start-up check (ros/run.py) read a file with
`parse_params_file`, so a file gets one verdict and the same lines everywhere. It walks the
sections as rcl's parser does (nested namespace keys joined with '/'), refuses what rcl would
refuse and any section that addresses no node of the suite, and `ParamsFile.values_for` merges
the sections that match a node as rclpy does. `load_params` is the entry point of the science:
the planner's values from the file, then the overrides, all validated at once by
`params.params_from_mapping`.
"""
from __future__ import annotations

import difflib
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from uav_insar_planner.param_specs.nodes import SUITE_PARAMETER_NAMES, spec_named
from uav_insar_planner.param_specs.science import PAPER_VALUES, SPEC_BY_NAME
from uav_insar_planner.params import ParamError, Params, params_from_mapping, shown
from uav_insar_planner.swarm import MASTER, MAX_UAVS, agent_name, uavs

PARAMS_FILE_MAX_BYTES = 1 << 20
#: The nodes a section may address: the executables' own names, and the agents as the demo
#: starts them (`-r __node:=agentK`, one per UAV of the largest swarm).
SUITE_NODE_NAMES = ("planner", "agent", "mavlink_bridge",
                    *(agent_name(k) for k in uavs(MAX_UAVS)))
SUITE_NODE_KINDS = ("planner", "agent", f"{agent_name(MASTER)}..{agent_name(MAX_UAVS - 1)}",
                    "mavlink_bridge")
SECTIONS_EXPECTED = "expected '/**:' or 'NODE:' sections with ros__parameters"
# One part of a section's node name as rcl's parser allows it: a ROS name token, * or **.
_NAME_PART = re.compile(r"\*\*?|[A-Za-z_][A-Za-z0-9_]*")


# ROS 2 integer parameters are 64-bit; a longer literal is refused before Python converts it
# (a 5000-digit one would pass its int-str limit).
INT_LITERAL_MAX_DIGITS = 19


class _RosYamlLoader(yaml.SafeLoader):
    """YAML 1.1 safe loader that also reads `1e9` and `1.0e9` as floats, as ROS 2's params
    parser does (PyYAML's 1.1 resolver wants a signed exponent), `null`, `~` and dates as the
    text they are (rcl has no null or date type: `a: null` is the string 'null' to a node), and
    refuses what a params file never needs: aliases (nested ones make a few hundred bytes
    expand to gigabytes), mapping keys that are not strings (`1:`, `null:`, `yes:`), duplicate
    keys (YAML would silently keep the last) and integers of more than INT_LITERAL_MAX_DIGITS
    digits."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.events.AliasEvent):
            raise yaml.composer.ComposerError(None, None, "aliases are not allowed",
                                              self.peek_event().start_mark)
        return super().compose_node(parent, index)

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        seen: set[str] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key_node.tag != "tag:yaml.org,2002:str":
                text = (shown(key_node.value)[1:-1] if isinstance(key_node, yaml.ScalarNode)
                        else shown(key))  # as written: `yes`, `null`, `1`
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {text} is not a name (quote it if it is one)",
                    key_node.start_mark)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {shown(key)}", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)

    def construct_yaml_int(self, node: Any) -> int:
        digits = sum(c.isdigit() for c in str(node.value))
        if digits > INT_LITERAL_MAX_DIGITS:
            raise yaml.constructor.ConstructorError(
                None, None, f"integer of {digits} digits (at most {INT_LITERAL_MAX_DIGITS}: "
                "ROS 2 integers are 64-bit; write a float as 1.0e30)", node.start_mark)
        return super().construct_yaml_int(node)


_RosYamlLoader.add_constructor("tag:yaml.org,2002:int", _RosYamlLoader.construct_yaml_int)
for _tag in ("null", "timestamp"):
    _RosYamlLoader.add_constructor(f"tag:yaml.org,2002:{_tag}",
                                   yaml.SafeLoader.construct_scalar)
# launch_ros writes the lists of a launch file's parameter dict as `!!python/tuple` (it holds
# them as tuples); rcl's parser ignores the tag, and reads them as any sequence.
_RosYamlLoader.add_constructor("tag:yaml.org,2002:python/tuple",
                               yaml.SafeLoader.construct_yaml_seq)


_RosYamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)$"),
    list("-+0123456789."),
)


def yaml_load(text: str) -> Any:
    """Parse YAML the way ROS 2 params files are read (see _RosYamlLoader)."""
    return yaml.load(text, Loader=_RosYamlLoader)  # noqa: S506 - a SafeLoader subclass


def _where(path: str | Path) -> str:
    return f"params file {str(path)[:200]!r}"


def read_yaml_file(path: str | Path) -> Any:
    """The YAML document in file `path`; ParamError with one line when it is not a readable,
    UTF-8, alias-free YAML file of at most PARAMS_FILE_MAX_BYTES (read no further)."""
    where = _where(path)
    try:
        with open(path, "rb") as f:
            raw = f.read(PARAMS_FILE_MAX_BYTES + 1)
    except OSError as exc:
        raise ParamError([f"{where}: cannot be read ({exc.strerror or exc}); expected a "
                          "readable file"]) from None
    if len(raw) > PARAMS_FILE_MAX_BYTES:
        raise ParamError([f"{where}: larger than {PARAMS_FILE_MAX_BYTES} bytes; expected a "
                          "params file"])
    try:
        return yaml_load(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise ParamError([f"{where}: is not UTF-8 text; expected a YAML params file"]) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}" if mark else ""
        why = f" ({exc.problem})" if getattr(exc, "problem", None) else ""
        if isinstance(exc, yaml.constructor.ConstructorError):
            raise ParamError([f"{where}: is not a params file{at}{why}; expected '/**:' or "
                              "'NODE:' sections of unique names with ros__parameters"]) from None
        raise ParamError([f"{where}: is not valid YAML{at}{why}; {SECTIONS_EXPECTED}"]) from None


# --- sections: which node each addresses, and what it holds ---------------------------------

def _walk(doc: dict, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """(node name, body) of each section, as rcl's parser finds them: a mapping without
    ros__parameters whose values are all mappings is a namespace, its key joined with '/'."""
    for key, body in doc.items():
        name = f"{prefix}/{key}" if prefix else key
        if (isinstance(body, dict) and body and "ros__parameters" not in body
                and all(isinstance(v, dict) for v in body.values())):
            yield from _walk(body, name)
        else:
            yield name, body


def _flat(values: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Parameter values with nested mappings as dotted names (`a: {b: 1}` is `a.b`), as rcl."""
    out: dict[str, Any] = {}
    for key, value in values.items():
        name = f"{prefix}.{key}" if prefix else key
        if isinstance(value, dict) and value:
            out.update(_flat(value, name))
        else:
            out[name] = value
    return out


def _kind(value: Any) -> str:
    return {bool: "true/false", int: "integers", float: "floats", str: "strings"}.get(
        type(value), type(value).__name__)


def _section_problems(name: str, body: Any, own_name: str) -> list[str]:
    """What rcl (or the suite) refuses in one section, one line each."""
    parts = name[1:].split("/") if name.startswith("/") else name.split("/")
    if not all(_NAME_PART.fullmatch(p) for p in parts):
        return [f"section {shown(name)} is not a node name; expected '/'-separated parts of "
                "letters, digits and '_' (not starting with a digit), or * or **"]
    if not isinstance(body, dict) or not isinstance(body.get("ros__parameters"), dict):
        return [f"section {shown(name)} must hold a 'ros__parameters' mapping"]
    if len(body) > 1:
        other = next(k for k in body if k != "ros__parameters")
        return [f"section {shown(name)} must hold only a 'ros__parameters' mapping (not "
                f"{shown(other)})"]
    node = parts[-1]
    if node not in ("*", "**", own_name, *SUITE_NODE_NAMES):
        near = difflib.get_close_matches(node, [*SUITE_NODE_NAMES, own_name], n=1)
        hint = f" (did you mean {near[0]}?)" if near else ""
        return [f"section {shown(name)} names no node of uav_insar_planner{hint}; expected "
                f"/**, {', '.join(SUITE_NODE_KINDS)} or this node's name"]
    problems, values = [], dict(body["ros__parameters"])
    for param, value in body["ros__parameters"].items():
        if isinstance(value, dict) and value and param in SUITE_PARAMETER_NAMES:
            # rcl would read `ground_station_m: {x: 1}` as a parameter ground_station_m.x,
            # which no node takes: the mapping is the mistake, said once
            spec = spec_named(param, "agent" if node.startswith("agent") else node)
            problems.append(f"section {shown(name)}: {param}: value {shown(value)} is not "
                            "allowed (a mapping); expected "
                            + (spec.allowed() if spec else "true or false"))
            del values[param]
    for param, value in _flat(values).items():
        kinds = {_kind(v) for v in value} if isinstance(value, list) else set()
        if len(kinds) > 1:
            problems.append(f"section {shown(name)}: {param}: value {shown(value)} mixes "
                            f"{' and '.join(sorted(kinds))}; expected a list of one type, as "
                            "ROS 2 parameters are (write 70.0, not 70, among floats)")
    return problems


@dataclass(frozen=True)
class ParamsFile:
    """A params file that rcl would accept and whose sections all address nodes of the suite:
    each section's node name (nested namespaces joined with '/') and its values (nested
    names dotted), in rcl's order: the order in which each name first appears."""

    path: str
    sections: Mapping[str, Mapping[str, Any]]

    def values_for(self, node: str = "planner") -> dict[str, Any]:
        """The values node `node` (a name, or a fully qualified /NS/NAME) gets, as rclpy
        merges them: every section whose name matches, in file order, a later one winning."""
        fqn = node if node.startswith("/") else f"/{node}"
        values: dict[str, Any] = {}
        for name, section in self.sections.items():
            if section_matches(name, fqn):
                values.update(section)
        return values


def section_matches(name: str, fqn: str) -> bool:
    """Whether section `name` addresses the node of fully qualified name `fqn`, by rclpy's
    rule: a leading '/' is implied, `/*` is one namespace part or name, `/**` any number."""
    name = name if name.startswith("/") else f"/{name}"
    pattern = name.replace("/*", r"(/\w+)")  # "/**" becomes (/\w+)*, as in rclpy
    return re.fullmatch(pattern, fqn, re.ASCII) is not None


def parse_params_file(path: str | Path, own_name: str = "planner") -> ParamsFile:
    """Read and check a ROS 2 params file. ParamError lists every problem, one line each,
    when rcl would refuse it or a section addresses no node of the suite (nor `own_name`)."""
    where = _where(path)
    doc = read_yaml_file(path)
    if doc is None or doc == {}:
        raise ParamError([f"{where}: is empty; {SECTIONS_EXPECTED}"])
    if not isinstance(doc, dict):
        raise ParamError([f"{where}: must map node names to {{ros__parameters: {{...}}}}; "
                          f"{SECTIONS_EXPECTED}"])
    sections: dict[str, dict[str, Any]] = {}
    problems = []
    for name, body in _walk(doc):
        found = _section_problems(name, body, own_name)
        problems += [f"{where}: {line}" for line in found]
        if not found:
            sections.setdefault(name, {}).update(_flat(body["ros__parameters"]))
    if problems:
        raise ParamError(problems)
    return ParamsFile(str(path), sections)


def params_file_problems(path: str | Path, own_name: str = "planner") -> list[str]:
    """One line per problem of params file `path` (none: it is fine)."""
    try:
        parse_params_file(path, own_name)
    except ParamError as exc:
        return exc.problems
    return []


def read_params_file(path: str | Path, node_name: str = "planner") -> dict[str, Any]:
    """The values node `node_name` gets from params file `path` (ParamsFile.values_for);
    ParamError, one line per problem, as parse_params_file."""
    return parse_params_file(path, node_name.rsplit("/", 1)[-1]).values_for(node_name)


def parse_override(text: str) -> tuple[str, Any]:
    """`NAME=VALUE` (CLI --set) or `NAME:=VALUE` (ROS -p), VALUE parsed as YAML."""
    sep = ":=" if ":=" in text else "="
    name, eq, raw = text.partition(sep)
    if not eq or not name.strip():
        raise ParamError([f"--set: value {shown(text)} is not allowed; expected NAME=VALUE"])
    try:
        value = yaml_load(raw)
    except yaml.YAMLError:
        value = raw
    return name.strip(), value


def not_for_the_scenario(values: Mapping[Any, Any]) -> list[str]:
    """The names in `values` that another node of the suite takes but the planner's scenario
    does not (`offloading`, `connections`, `uav_timeout_s`, rclpy's `use_sim_time`): the
    planner node leaves them to their nodes, and so does `load_params`."""
    return [name for name in values
            if name in SUITE_PARAMETER_NAMES and name not in SPEC_BY_NAME]


def load_params(path: str | Path | None = None, overrides: Mapping[str, Any] | None = None,
                node_name: str = "planner", paper: bool = False) -> Params:
    """Load a params file (none: Table I defaults, as in config/params.yaml), apply overrides,
    validate everything at once and convert to SI. Raises ParamError listing every problem.

    `paper`: the paper's problem (P), every field-only default (PAPER_VALUES: rate_margin 0)
    set back to the paper's value over the file's; an override of the same name still wins.

    The planner's verdict on names: another node's parameter (not_for_the_scenario), from the
    file or the overrides, is ignored, as `-p` and `/**` serve every node; a name no node
    takes is refused in `params.unknown_parameter`'s words."""
    values = read_params_file(path, node_name) if path is not None else {}
    if paper:
        values.update(PAPER_VALUES)
    if overrides:
        values.update(overrides)
    for name in not_for_the_scenario(values):
        del values[name]
    return params_from_mapping(values)
