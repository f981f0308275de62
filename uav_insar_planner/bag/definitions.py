"""Message definitions for a bag: the full `ros2msg` text and the RIHS01 hash of a ROS type,
read from the interface files that every ROS 2 install ships (no ROS import, no
rosidl_runtime_py).

Where the files are: `<prefix>/share/<package>/msg/<Type>.msg` (and `<Type>.json`, the type
description with its hashes), for each prefix of AMENT_PREFIX_PATH (a sourced Jazzy, a colcon
install) and then this Python's own prefix (the PyPI wheels install into the venv's share/).

`full_definition(type)` is the text rosbag2 stores as an MCAP schema (encoding `ros2msg`,
rosbag2_storage_mcap's LocalMessageDefinitionSource): the type's .msg file as is, then for each
type it depends on, depth first, each once, dependencies of one type in sorted order:

    "\\n" + "=" * 80 + "\\nMSG: pkg/Type\\n" + <that type's .msg text>
"""
from __future__ import annotations

import functools
import json
import os
import re
import sys
from pathlib import Path

SEPARATOR = "=" * 80
BUILTIN_TYPES = frozenset({
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
    "uint32", "int64", "uint64", "string", "wstring"})
_TYPE_NAME = re.compile(r"^([A-Za-z][A-Za-z0-9_]*)/(?:msg/)?([A-Za-z][A-Za-z0-9_]*)$")


class DefinitionError(LookupError):
    """A type's interface file is missing or unreadable (the message says which, and where)."""


def split_type(type_name: str) -> tuple[str, str]:
    """'geometry_msgs/msg/PoseArray' or 'geometry_msgs/PoseArray' -> ('geometry_msgs',
    'PoseArray'); ValueError for anything else."""
    m = _TYPE_NAME.match(type_name)
    if not m:
        raise ValueError(f"message type {type_name[:80]!r} is not allowed; expected "
                         "package/msg/Type")
    return m[1], m[2]


def share_prefixes() -> list[Path]:
    """Install prefixes searched, in order: AMENT_PREFIX_PATH, then sys.prefix."""
    prefixes = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    return [*prefixes, Path(sys.prefix)]


def interface_file(type_name: str, suffix: str) -> Path:
    """The `<Type><suffix>` file (.msg or .json) of `type_name`; DefinitionError if none."""
    package, name = split_type(type_name)
    for prefix in share_prefixes():
        path = prefix / "share" / package / "msg" / f"{name}{suffix}"
        if path.is_file():
            return path
    where = ", ".join(str(p / "share") for p in share_prefixes())
    raise DefinitionError(f"no {package}/msg/{name}{suffix} under {where}; install the "
                          f"package that defines {package}/msg/{name}")


def dependencies(text: str, package: str) -> list[str]:
    """The message types ('pkg/Type') the fields of .msg `text` use, sorted, each once.

    A bare name is of the same package, except Header (std_msgs/Header); constants
    (`type NAME=value`) and builtin types add nothing."""
    found = set()
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.split()
        if len(parts) < 2 or "=" in parts[1] or (len(parts) > 2 and parts[2].startswith("=")):
            continue  # not a field: a constant
        base = re.sub(r"\[.*\]$", "", parts[0])  # arrays: T[], T[3], T[<=3]
        base = re.sub(r"<=\d+$", "", base)  # bounded strings: string<=10
        if base in BUILTIN_TYPES:
            continue
        if "/" in base:
            dep_package, dep_name = split_type(base)
        elif base == "Header":
            dep_package, dep_name = "std_msgs", "Header"
        else:
            dep_package, dep_name = package, base
        found.add(f"{dep_package}/{dep_name}")
    return sorted(found)


@functools.cache
def msg_text(type_name: str) -> str:
    """The .msg file of `type_name`, as is."""
    try:
        return interface_file(type_name, ".msg").read_text(encoding="utf-8")
    except OSError as exc:  # unreadable file
        raise DefinitionError(f"{type_name}: {exc}") from None


@functools.cache
def full_definition(type_name: str) -> str:
    """The rosbag2 `ros2msg` schema text of `type_name` (see the module docstring)."""
    seen: set[str] = set()

    def expand(name: str) -> str:
        package, _ = split_type(name)
        text = msg_text(name)
        out = text
        for dep in dependencies(text, package):
            if dep not in seen:
                seen.add(dep)
                out += f"\n{SEPARATOR}\nMSG: {dep}\n" + expand(dep)
        return out

    return expand(type_name)


@functools.cache
def type_hash(type_name: str) -> str:
    """The type's RIHS01 hash (`RIHS01_<64 hex>`), from its .json type description."""
    package, name = split_type(type_name)
    try:
        doc = json.loads(interface_file(type_name, ".json").read_text(encoding="utf-8"))
        wanted = f"{package}/msg/{name}"
        return next(h["hash_string"] for h in doc["type_hashes"] if h["type_name"] == wanted)
    except (OSError, ValueError, KeyError, TypeError, StopIteration) as exc:
        raise DefinitionError(f"{type_name}: no type hash in its .json ({exc!r:.80})") from None


def canonical_type(type_name: str) -> str:
    """'pkg/Type' or 'pkg/msg/Type' -> 'pkg/msg/Type', the name rosbag2 records."""
    package, name = split_type(type_name)
    return f"{package}/msg/{name}"
