"""rclpy.parameter.Parameter and the rcl_interfaces parameter messages."""
from __future__ import annotations

import enum
from typing import Any

from .messages import get_message

ParameterDescriptor = get_message("rcl_interfaces/msg/ParameterDescriptor")
FloatingPointRange = get_message("rcl_interfaces/msg/FloatingPointRange")
IntegerRange = get_message("rcl_interfaces/msg/IntegerRange")
ParameterType = get_message("rcl_interfaces/msg/ParameterType")
ParameterValue = get_message("rcl_interfaces/msg/ParameterValue")
SetParametersResult = get_message("rcl_interfaces/msg/SetParametersResult")
ParameterMsg = get_message("rcl_interfaces/msg/Parameter")

_ARRAY_KINDS = ((bool, 6), (int, 7), (float, 8), (str, 9))
_VALUE_FIELDS = {1: "bool_value", 2: "integer_value", 3: "double_value", 4: "string_value",
                 5: "byte_array_value", 6: "bool_array_value", 7: "integer_array_value",
                 8: "double_array_value", 9: "string_array_value"}


class Parameter:
    """A named, typed parameter value (rclpy semantics: the type is inferred from the value
    when not given; an int is not a double)."""

    class Type(enum.IntEnum):
        NOT_SET = 0
        BOOL = 1
        INTEGER = 2
        DOUBLE = 3
        STRING = 4
        BYTE_ARRAY = 5
        BOOL_ARRAY = 6
        INTEGER_ARRAY = 7
        DOUBLE_ARRAY = 8
        STRING_ARRAY = 9

        @classmethod
        def from_parameter_value(cls, value: Any) -> Parameter.Type:
            """The type rclpy infers for a Python value; TypeError if none fits."""
            if value is None:
                return cls.NOT_SET
            if isinstance(value, bool):
                return cls.BOOL
            if isinstance(value, int):
                return cls.INTEGER
            if isinstance(value, float):
                return cls.DOUBLE
            if isinstance(value, str):
                return cls.STRING
            if isinstance(value, bytes):
                return cls.BYTE_ARRAY
            if isinstance(value, (list, tuple)):
                for kind, code in _ARRAY_KINDS:
                    if all(type(v) is kind for v in value):
                        return cls(code)
            raise TypeError(f"the parameter value {value!r} is not one of the allowed types "
                            "(bool, int, float, str, bytes or a list of one of those)")

        def check(self, value: Any) -> bool:
            try:
                return Parameter.Type.from_parameter_value(value) == self or (
                    self in _ARRAY_TYPES and isinstance(value, (list, tuple)) and not value)
            except TypeError:
                return False

    def __init__(self, name: str, type_: Parameter.Type | None = None,
                 value: Any = None) -> None:
        if type_ is None:
            type_ = Parameter.Type.from_parameter_value(value)
        type_ = Parameter.Type(type_)
        if type_ != Parameter.Type.NOT_SET and not type_.check(value):
            raise ValueError(f"type {type_.name} does not match the value {value!r}")
        self._name = name
        self._type = type_
        self._value = list(value) if isinstance(value, tuple) else value

    @property
    def name(self) -> str:
        return self._name

    @property
    def type_(self) -> Parameter.Type:
        return self._type

    @property
    def value(self) -> Any:
        return self._value

    def get_parameter_value(self) -> Any:
        """The value as an rcl_interfaces/msg/ParameterValue."""
        msg = ParameterValue(type=int(self._type))
        if self._type != Parameter.Type.NOT_SET:
            value = self._value
            if self._type == Parameter.Type.BYTE_ARRAY:
                value = list(value)
            setattr(msg, _VALUE_FIELDS[int(self._type)], value)
        return msg

    def to_parameter_msg(self) -> Any:
        return ParameterMsg(name=self._name, value=self.get_parameter_value())

    @classmethod
    def from_parameter_msg(cls, msg: Any) -> Parameter:
        """The Parameter an rcl_interfaces/msg/Parameter carries: the value field its type code
        names, the others ignored (as rclpy). ValueError for an unknown type code."""
        type_ = Parameter.Type(msg.value.type)
        if type_ == Parameter.Type.NOT_SET:
            return cls(msg.name, type_)
        value = getattr(msg.value, _VALUE_FIELDS[int(type_)])
        if type_ == Parameter.Type.BYTE_ARRAY:
            value = bytes(value)  # our BYTE_ARRAY holds bytes; the wire gives a list of ints
        elif type_ in _ARRAY_TYPES:
            value = list(value)
        return cls(msg.name, type_, value)

    def __repr__(self) -> str:
        return f"Parameter(name={self._name!r}, type_={self._type.name}, value={self._value!r})"

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Parameter) and (self._name, self._type, self._value)
                == (other._name, other._type, other._value))

    __hash__ = None  # type: ignore[assignment]


_ARRAY_TYPES = frozenset(Parameter.Type(c) for c in (5, 6, 7, 8, 9))
