"""One ROS message as the YAML text `ros2 topic echo` prints (rosidl_runtime_py's format).

Contract of `message_to_yaml(msg)`: for any rclpy message object, the exact text ros2 topic echo
(Jazzy, default options) prints for it, without the `---` line that follows; it ends in a newline.
Fields come in `get_fields_and_field_types()` order, nested messages become nested mappings,
sequences/arrays (list, array.array, numpy.ndarray) become block lists of Python scalars, numpy
scalars become Python scalars, `bytes` (byte/octet values) become the string of their
characters, floats print as PyYAML does (`0.0`, `1.0e-05`, `.nan`, `.inf`). As ros2 topic echo,
strings, bytes and sequences longer than `truncate_length` (default 128, ros2's
`--truncate-length`) are cut to that length and followed by `...`; `None` prints in full.
"""
from __future__ import annotations

import array
import sys
from typing import Any

import numpy
import yaml

TRUNCATE_LENGTH = 128


def message_to_yaml(msg: Any, *, truncate_length: int | None = TRUNCATE_LENGTH) -> str:
    """The text `ros2 topic echo` prints for `msg` (without `---`); see the module docstring."""
    return yaml.safe_dump(_plain(msg, truncate_length), default_flow_style=False,
                          sort_keys=False, allow_unicode=True, width=sys.maxsize)


def _plain(value: Any, n: int | None) -> Any:
    """`value` as dicts, lists and Python scalars, truncated to `n` items like rosidl_runtime_py."""
    if isinstance(value, (bytes, str, list, tuple, array.array, numpy.ndarray)):
        more = n is not None and len(value) > n
        head = value[:n] if more else value
        if isinstance(value, bytes):
            return "".join(map(chr, head)) + ("..." if more else "")
        if isinstance(value, str):
            return head + ("..." if more else "")
        return [_plain(v, n) for v in head] + (["..."] if more else [])
    if isinstance(value, numpy.generic):
        return value.item()
    if isinstance(value, (bool, int, float)):
        return value
    return {name: _plain(getattr(value, name, None), n)
            for name in value.get_fields_and_field_types()}
