"""ROS 2 message and service classes generated from the rosbags Jazzy typestore.

`get_message("geometry_msgs/msg/Pose")` returns a cyclonedds `IdlStruct` dataclass whose DDS
type name is `geometry_msgs::msg::dds_::Pose_` and whose XCDR1 bytes equal rosbags'
`serialize_cdr`. Classes are built lazily, once per type, and behave like rclpy messages for
construction: `Pose()`, keyword arguments, nested defaults, lists for sequences, class-level
constants (`DiagnosticStatus.WARN`). `get_service("std_srvs/srv/Trigger")` returns a class
with `Request` and `Response` attributes, as rclpy's generated service classes have.

Known differences from rclpy: `byte` fields hold an int (assigning a 1-byte `bytes` is
accepted and converted), fixed `uint8`/`char` arrays come back from the wire as `bytes`,
no type checking on assignment.
"""
from __future__ import annotations

import dataclasses
import threading
from typing import Any

from cyclonedds.idl import IdlMeta, IdlStruct
from cyclonedds.idl import types as t
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)

# rosbags carries no service definitions; these are the Jazzy .srv files we support, as the
# request and response halves in .msg syntax (relative type names resolve to the package's msg
# types). An empty half gets rosidl's placeholder member.
_SERVICES: dict[str, tuple[str, str]] = {
    "std_srvs/srv/Trigger": ("", "bool success\nstring message"),
    "std_srvs/srv/Empty": ("", ""),
    "std_srvs/srv/SetBool": ("bool data", "bool success\nstring message"),
    "rcl_interfaces/srv/DescribeParameters": ("string[] names",
                                              "ParameterDescriptor[] descriptors"),
    "rcl_interfaces/srv/GetParameters": ("string[] names", "ParameterValue[] values"),
    "rcl_interfaces/srv/GetParameterTypes": ("string[] names", "uint8[] types"),
    "rcl_interfaces/srv/ListParameters": (
        "uint64 DEPTH_RECURSIVE=0\nstring[] prefixes\nuint64 depth",
        "ListParametersResult result"),
    "rcl_interfaces/srv/SetParameters": ("Parameter[] parameters",
                                         "SetParametersResult[] results"),
    "rcl_interfaces/srv/SetParametersAtomically": ("Parameter[] parameters",
                                                   "SetParametersResult result"),
}

# Field defaults written in the Jazzy .msg files (rosbags drops them). Derived by reading the
# .msg files of every package in the typestore that our nodes use; Quaternion is the only one
# of those with a non-zero default (`float64 w 1`).
FIELD_DEFAULTS: dict[str, dict[str, Any]] = {
    "geometry_msgs/msg/Quaternion": {"w": 1.0},
}

_PRIMITIVES = {
    "bool": (bool, False),
    "byte": (t.uint8, 0),
    "char": (t.uint8, 0),
    "int8": (t.int8, 0),
    "uint8": (t.uint8, 0),
    "int16": (t.int16, 0),
    "uint16": (t.uint16, 0),
    "int32": (t.int32, 0),
    "uint32": (t.uint32, 0),
    "int64": (t.int64, 0),
    "uint64": (t.uint64, 0),
    "float32": (t.float32, 0.0),
    "float64": (t.float64, 0.0),
}

_LOCK = threading.RLock()
_MESSAGES: dict[str, type] = {}
_SERVICE_CLASSES: dict[str, type] = {}


def _register_services() -> None:
    """Add every `_SERVICES` half to the typestore as `pkg/srv/Name_Request` / `_Response`, so
    rosbags can serialize them and compute their RIHS01 hashes like any message type."""
    placeholder = ("structure_needs_at_least_one_member", (Nodetype.BASE, ("uint8", 0)))
    defs = {}
    for srv, halves in _SERVICES.items():
        pkg, _kind, name = srv.split("/")
        for suffix, text in zip(("_Request", "_Response"), halves, strict=True):
            # The .msg parser only knows msg names; parse as one, register under the srv name.
            parsed = get_types_from_msg(text, f"{pkg}/msg/{name}{suffix}")
            consts, fields = next(iter(parsed.values()))
            defs[srv + suffix] = (consts, fields or [placeholder])
    TYPESTORE.register(defs)


_register_services()


def dds_typename(ros_type: str) -> str:
    """`pkg/msg/Name` -> `pkg::msg::dds_::Name_` (the name rmw_cyclonedds registers)."""
    pkg, kind, name = ros_type.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def ros_typename(dds_type: str) -> str:
    """Inverse of `dds_typename`; raises ValueError for a non-ROS type name."""
    parts = dds_type.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_"):
        raise ValueError(f"not a ROS 2 DDS type name: {dds_type!r}")
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"


def _field_type(desc: tuple) -> tuple[Any, Any]:
    """Map a rosbags field description to (cyclonedds annotation, dataclasses.field)."""
    kind, rest = desc
    if kind == Nodetype.BASE:
        name, bound = rest
        if name == "string":
            return (t.bounded_str[bound] if bound else str), dataclasses.field(default="")
        if name not in _PRIMITIVES:
            raise TypeError(f"unsupported primitive type {name}")
        annot, default = _PRIMITIVES[name]
        return annot, dataclasses.field(default=default)
    if kind == Nodetype.NAME:
        cls = get_message(rest)
        return cls, dataclasses.field(default_factory=cls)
    inner, size = rest
    inner_annot, inner_field = _field_type(inner)
    if kind == Nodetype.ARRAY:
        if inner_field.default_factory is not dataclasses.MISSING:
            factory = inner_field.default_factory
            return t.array[inner_annot, size], dataclasses.field(
                default_factory=lambda: [factory() for _ in range(size)])
        value = inner_field.default
        return t.array[inner_annot, size], dataclasses.field(
            default_factory=lambda: [value] * size)
    annot = t.sequence[inner_annot, size] if size else t.sequence[inner_annot]
    return annot, dataclasses.field(default_factory=list)


def _normalizing_setattr(byte_fields: frozenset[str], list_fields: frozenset[str]):
    """A __setattr__ that accepts what rclpy accepts: a 1-byte `bytes` for a byte field, and
    numpy arrays, tuples or array.array for sequences (cyclonedds wants lists)."""
    def __setattr__(self, name: str, value: Any) -> None:  # noqa: N807
        if name in list_fields and not isinstance(value, (list, bytes)):
            value = value.tolist() if hasattr(value, "tolist") else list(value)
        elif name in byte_fields and isinstance(value, (bytes, bytearray)) and len(value) == 1:
            value = value[0]
        object.__setattr__(self, name, value)
    return __setattr__


def _build(ros_type: str) -> type:
    consts, fields = TYPESTORE.fielddefs[ros_type]
    pkg, kind, name = ros_type.split("/")
    ns = IdlMeta.__prepare__(name, (IdlStruct,), typename=dds_typename(ros_type))
    defaults = FIELD_DEFAULTS.get(ros_type, {})
    byte_fields, list_fields = [], []
    for fname, desc in fields:
        annot, fld = _field_type(desc)
        if fname in defaults:
            fld = dataclasses.field(default=defaults[fname])
        ns["__annotations__"][fname] = annot
        ns[fname] = fld
        if desc[0] == Nodetype.BASE and desc[1][0] == "byte":
            byte_fields.append(fname)
        if desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            list_fields.append(fname)
    cls = IdlMeta(name, (IdlStruct,), ns, typename=dds_typename(ros_type))
    cls = dataclasses.dataclass(cls)
    for cname, _ctype, cvalue in consts:
        setattr(cls, cname, cvalue)
    if byte_fields or list_fields:
        cls.__setattr__ = _normalizing_setattr(frozenset(byte_fields), frozenset(list_fields))
    cls.__module__ = f"{pkg}.{kind}"
    cls._ros_type = ros_type
    cls._field_types = {fname: desc for fname, desc in fields}
    cls.get_fields_and_field_types = classmethod(
        lambda c: {f: _describe(d) for f, d in c._field_types.items()})
    return cls


def _describe(desc: tuple) -> str:
    kind, rest = desc
    if kind == Nodetype.BASE:
        return rest[0] if not rest[1] else f"{rest[0]}<={rest[1]}"
    if kind == Nodetype.NAME:
        return rest.replace("/msg/", "/")
    inner, size = rest
    base = _describe(inner)
    if kind == Nodetype.ARRAY:
        return f"{base}[{size}]"
    return f"sequence<{base}, {size}>" if size else f"sequence<{base}>"


def get_message(ros_type: str) -> type:
    """Return the generated class for `pkg/msg/Name` (built on first use).

    Raises KeyError with the type name when the Jazzy typestore has no such type.
    """
    with _LOCK:
        cls = _MESSAGES.get(ros_type)
        if cls is None:
            if ros_type not in TYPESTORE.fielddefs:
                raise KeyError(f"unknown message type {ros_type!r}")
            cls = _MESSAGES[ros_type] = _build(ros_type)
        return cls


def get_service(srv_type: str) -> type:
    """Return a class with `Request` and `Response` for `pkg/srv/Name` (see _SERVICES)."""
    with _LOCK:
        cls = _SERVICE_CLASSES.get(srv_type)
        if cls is None:
            if srv_type not in _SERVICES:
                raise KeyError(f"unknown service type {srv_type!r}")
            pkg, _kind, name = srv_type.split("/")
            cls = type(name, (), {
                "Request": get_message(srv_type + "_Request"),
                "Response": get_message(srv_type + "_Response"),
                "_ros_type": srv_type,
                "__module__": f"{pkg}.srv",
            })
            _SERVICE_CLASSES[srv_type] = cls
        return cls


def msg_type(name: str) -> type:
    """Message or service class by its ROS name, e.g. `std_srvs/srv/Trigger`."""
    parts = name.split("/")
    if len(parts) != 3 or parts[1] not in ("msg", "srv"):
        raise ValueError(f"expected 'pkg/msg/Name' or 'pkg/srv/Name', got {name!r}")
    return get_service(name) if parts[1] == "srv" else get_message(name)


def type_hash(ros_type: str) -> str:
    """The RIHS01 type hash string of a message type (rosbags computes it)."""
    return TYPESTORE.hash_rihs01(ros_type)
