"""`--ros-args` parsing, as rcl does it for the subset we support.

Supported inside `--ros-args ... [--]`: `-p/--param [node:]name:=value` (value read as YAML),
`--params-file FILE` (`/**`, `node`, `/ns/node`, wildcard and nested-namespace sections),
`-r/--remap [node:]from:=to` (incl. `__node:=NAME` and `__ns:=/NS`), `--log-level [name:=]LEVEL`
and `-e/--enclave` (accepted, unused). Anything else raises InvalidRosArgumentsError.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..params import yaml_load
from .exceptions import InvalidRosArgumentsError
from .logging import parse_severity


@dataclass
class ParamSource:
    """Parameter values for the nodes whose fully qualified name matches `pattern`."""

    pattern: str
    values: dict[str, Any]


@dataclass
class RosArguments:
    params: list[ParamSource] = field(default_factory=list)
    remaps: list[tuple[str | None, str, str]] = field(default_factory=list)
    log_levels: dict[str, str] = field(default_factory=dict)
    non_ros: list[str] = field(default_factory=list)

    def overrides_for(self, fq_node_name: str) -> dict[str, Any]:
        """Parameter overrides that apply to a node; later sources win, as in rcl."""
        merged: dict[str, Any] = {}
        for src in self.params:
            if node_pattern_matches(src.pattern, fq_node_name):
                merged.update(src.values)
        return merged

    def remap_for(self, node_name: str, key: str) -> str | None:
        """Last `__node` / `__ns` remap (key) that applies to a node with this name."""
        found = None
        for target, frm, to in self.remaps:
            if frm == key and target in (None, node_name):
                found = to
        return found

    def topic_remaps(self, node_name: str) -> list[tuple[str, str]]:
        return [(frm, to) for target, frm, to in self.remaps
                if not frm.startswith("__") and target in (None, node_name)]


def node_pattern_matches(pattern: str, fq_name: str) -> bool:
    """rcl node-name matching: `/**` any, `*` one token, `**` any number of tokens; a name
    without a leading slash is absolute."""
    rx = ""
    for tok in pattern.strip("/").split("/"):
        rx += {"**": "(?:/[^/]+)*", "*": "/[^/]+"}.get(tok, "/" + re.escape(tok))
    return re.fullmatch(rx, fq_name) is not None


def _flatten(prefix: str, value: Any, out: dict[str, Any], where: str) -> None:
    if isinstance(value, dict):
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, out, where)
        return
    out[prefix] = check_value(prefix, value, where)


def check_value(name: str, value: Any, where: str) -> Any:
    """Accept what an rcl parameter can hold; raise InvalidRosArgumentsError otherwise."""
    if isinstance(value, list):
        kinds = {type(v) for v in value}
        if len(kinds) > 1 or (kinds and not kinds <= {bool, int, float, str}):
            raise InvalidRosArgumentsError(
                f"{where}: parameter '{name}': a list must hold values of one type "
                f"(bool, integer, double or string), got {value!r}")
        return value
    if value is None or isinstance(value, dict) or not isinstance(value, (bool, int, float, str)):
        raise InvalidRosArgumentsError(f"{where}: parameter '{name}' has no usable value")
    return value


def load_params_file(path: str) -> list[ParamSource]:
    """Read a ROS 2 params file into sources, in file order."""
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise InvalidRosArgumentsError(
            f"--params-file {path}: cannot read it ({exc.strerror})") from None
    try:
        data = yaml_load(text)
    except Exception as exc:  # noqa: BLE001 - any YAML error is the user's file
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InvalidRosArgumentsError(f"--params-file {path}: not valid YAML: {first}") from None
    if not isinstance(data, dict):
        raise InvalidRosArgumentsError(
            f"--params-file {path}: expected a mapping of node names to 'ros__parameters'")
    sources: list[ParamSource] = []

    def walk(node_path: list[str], mapping: dict) -> None:
        for key, value in mapping.items():
            if key == "ros__parameters":
                if not node_path or not isinstance(value, dict):
                    raise InvalidRosArgumentsError(
                        f"--params-file {path}: 'ros__parameters' must be a mapping under a "
                        "node name")
                out: dict[str, Any] = {}
                _flatten("", value, out, f"--params-file {path}")
                sources.append(ParamSource("/" + "/".join(p.strip("/") for p in node_path),
                                           out))
            elif isinstance(value, dict):
                walk(node_path + [str(key)], value)
            else:
                raise InvalidRosArgumentsError(
                    f"--params-file {path}: '{key}' is not under a node's 'ros__parameters'")

    walk([], data)
    return sources


def _split_assign(flag: str, text: str) -> tuple[str | None, str, str]:
    if ":=" not in text:
        raise InvalidRosArgumentsError(f"{flag} {text!r}: expected NAME:=VALUE")
    lhs, rhs = text.split(":=", 1)
    node = None
    if ":" in lhs:
        node, lhs = lhs.split(":", 1)
    if not lhs:
        raise InvalidRosArgumentsError(f"{flag} {text!r}: empty name")
    return node, lhs, rhs


def parse(argv: list[str]) -> RosArguments:
    """Split argv into ROS arguments (parsed) and the rest (kept in `non_ros`, argv[0]
    included). Raises InvalidRosArgumentsError on the first bad ROS argument."""
    out = RosArguments()
    i, in_ros = 0, False
    while i < len(argv):
        arg = argv[i]
        i += 1
        if arg == "--ros-args":
            in_ros = True
            continue
        if not in_ros:
            out.non_ros.append(arg)
            continue
        if arg == "--":
            in_ros = False
            continue
        if arg in ("-p", "--param", "-r", "--remap", "--params-file", "--log-level",
                   "-e", "--enclave"):
            if i >= len(argv) or argv[i] in ("--ros-args", "--"):
                raise InvalidRosArgumentsError(f"{arg} needs a value")
            value = argv[i]
            i += 1
            if arg in ("-p", "--param"):
                node, name, raw = _split_assign(arg, value)
                try:
                    parsed = yaml_load(raw) if raw else ""
                except Exception:  # noqa: BLE001
                    parsed = raw
                out.params.append(ParamSource(
                    node or "/**", {name: check_value(name, parsed, f"{arg} {value}")}))
            elif arg in ("-r", "--remap"):
                node, frm, to = _split_assign(arg, value)
                if not to:
                    raise InvalidRosArgumentsError(f"{arg} {value!r}: empty replacement")
                out.remaps.append((node, frm, to))
            elif arg == "--params-file":
                out.params.extend(load_params_file(value))
            elif arg == "--log-level":
                name, level = ("", value)
                if ":=" in value:
                    name, level = value.split(":=", 1)
                try:
                    parse_severity(level)
                except ValueError as exc:
                    raise InvalidRosArgumentsError(f"--log-level: {exc}") from None
                out.log_levels[name] = level
            continue
        raise InvalidRosArgumentsError(f"unknown ROS argument {arg!r} (supported: -p, "
                                       "--params-file, -r, --log-level, -e)")
    return out


def remove_ros_args(args: list[str]) -> list[str]:
    """rclpy.utilities.remove_ros_args: argv without the --ros-args sections."""
    out, in_ros = [], False
    for arg in args:
        if arg == "--ros-args":
            in_ros = True
        elif in_ros and arg == "--":
            in_ros = False
        elif not in_ros:
            out.append(arg)
    return out
