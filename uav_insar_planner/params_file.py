"""Params files and overrides: ROS 2 params YAML and `NAME=VALUE` text to a validated Params.

`load_params` is the entry point: the file's "/**" section, then the node's own section, then
the overrides, all validated at once by `params.params_from_mapping`.
"""
from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from uav_insar_planner.params import ParamError, Params, params_from_mapping, shown

PARAMS_FILE_MAX_BYTES = 1 << 20


# ROS 2 integer parameters are 64-bit; a longer literal is refused before Python converts it
# (a 5000-digit one would pass its int-str limit).
INT_LITERAL_MAX_DIGITS = 19


class _RosYamlLoader(yaml.SafeLoader):
    """YAML 1.1 safe loader that also reads `1e9` and `1.0e9` as floats, as ROS 2's params
    parser does (PyYAML's 1.1 resolver wants a signed exponent), and refuses what a params file
    never needs: aliases (nested ones make a few hundred bytes expand to gigabytes), mapping
    keys that are not strings (`1:`, `null:`, `yes:`), duplicate keys (YAML would silently keep
    the last) and integers of more than INT_LITERAL_MAX_DIGITS digits."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.events.AliasEvent):
            raise yaml.composer.ComposerError(None, None, "aliases are not allowed",
                                              self.peek_event().start_mark)
        return super().compose_node(parent, index)

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        seen: set[str] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if not isinstance(key, str):
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {shown(key)} is not a name (quote it if it is one)",
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


_RosYamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)$"),
    list("-+0123456789."),
)


def yaml_load(text: str) -> Any:
    """Parse YAML the way ROS 2 params files are read (see _RosYamlLoader)."""
    return yaml.load(text, Loader=_RosYamlLoader)  # noqa: S506 - a SafeLoader subclass


def read_yaml_file(path: str | Path) -> Any:
    """The YAML document in file `path`; ParamError with one line when it is not a readable,
    UTF-8, alias-free YAML file of at most PARAMS_FILE_MAX_BYTES (read no further)."""
    where = f"params file {str(path)[:200]!r}"
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
        raise ParamError([f"{where}: is not valid YAML{at}{why}; expected '/**:' or 'NODE:' "
                          "sections with ros__parameters"]) from None


def read_params_file(path: str | Path, node_name: str = "planner") -> dict[str, Any]:
    """Read a ROS 2 params file: the "/**" section, then the node's own section on top.

    Node sections may be keyed by the node name with or without a leading slash or namespace
    (rclpy matches the fully qualified name; we accept `planner`, `/planner`, `/ns/planner`).
    Raises ParamError with one line when the file is unreadable or not in that format.
    """
    doc = read_yaml_file(path)
    if not isinstance(doc, dict):
        raise ParamError([f"params file {str(path)[:200]!r}: must map node names to "
                          "{ros__parameters: {...}}"])
    for key, body in doc.items():
        if not isinstance(body, dict) or not isinstance(body.get("ros__parameters"), dict):
            raise ParamError([f"params file {str(path)[:200]!r}: section {shown(key)} must hold "
                              "a 'ros__parameters' mapping"])
    values: dict[str, Any] = {}
    sections = [k for k in doc if k == "/**"] + [
        k for k in doc if isinstance(k, str) and k != "/**"
        and k.lstrip("/").split("/")[-1] == node_name]
    for key in sections:
        values.update(doc[key]["ros__parameters"])
    return values


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


def load_params(path: str | Path | None = None, overrides: Mapping[str, Any] | None = None,
                node_name: str = "planner") -> Params:
    """Load a params file (none: Table I defaults, as in config/params.yaml), apply overrides,
    validate everything at once and convert to SI. Raises ParamError listing every problem."""
    values = read_params_file(path, node_name) if path is not None else {}
    if overrides:
        values.update(overrides)
    return params_from_mapping(values)
