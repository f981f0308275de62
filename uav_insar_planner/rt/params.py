"""A node's ROS parameters: declaration with descriptors and ranges, get/set and the
set-parameters callbacks, with rclpy's semantics (types are fixed unless dynamic_typing;
overrides from --ros-args beat declared defaults; declaring runs the on-set callbacks)."""
from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

from .exceptions import (
    InvalidParameterTypeException,
    InvalidParameterValueException,
    ParameterAlreadyDeclaredException,
    ParameterNotDeclaredException,
    ParameterUninitializedException,
)
from .parameter import Parameter, ParameterDescriptor, SetParametersResult

_TOL = 1e-12


def range_error(value: Any, descriptor: Any) -> str | None:
    """Why `value` violates the descriptor's range, or None."""
    ranges = list(descriptor.floating_point_range) + list(descriptor.integer_range)
    if not ranges or isinstance(value, bool):
        return None
    values = value if isinstance(value, list) else [value]
    for rng in ranges:
        lo, hi, step = rng.from_value, rng.to_value, rng.step
        for v in values:
            if not isinstance(v, (int, float)):
                continue
            if isinstance(v, float) and math.isnan(v):
                return f"NaN is outside [{lo}, {hi}]"
            if v < lo - _TOL * max(1.0, abs(lo)) or v > hi + _TOL * max(1.0, abs(hi)):
                return f"{v} is outside the allowed range [{lo}, {hi}]"
            if step and not math.isclose(v, hi):
                k = (v - lo) / step
                if not math.isclose(k, round(k), abs_tol=1e-9):
                    return f"{v} is not {lo} plus a multiple of the step {step}"
    return None


class ParameterStore:
    def __init__(self, overrides: dict[str, Parameter], allow_undeclared: bool) -> None:
        self._lock = threading.RLock()
        self._values: dict[str, Parameter] = {}
        self._descriptors: dict[str, Any] = {}
        self.overrides = overrides
        self.allow_undeclared = allow_undeclared
        self._pre: list[Callable] = []
        self._on_set: list[Callable] = []
        self._post: list[Callable] = []
        # Told (new, changed) after every successful declare or set; the node publishes
        # /parameter_events from it.
        self.on_event: Callable[[list[Parameter], list[Parameter]], None] | None = None

    # --- declaring ------------------------------------------------------------------------
    def declare(self, name: str, value: Any = None, descriptor: Any = None,
                ignore_override: bool = False) -> Parameter:
        """rclpy Node.declare_parameter."""
        descriptor = ParameterDescriptor() if descriptor is None else descriptor
        with self._lock:
            if name in self._values:
                raise ParameterAlreadyDeclaredException(name)
            if isinstance(value, Parameter.Type):
                declared_type, default = value, None
            else:
                default = value.value if isinstance(value, Parameter) else value
                declared_type = Parameter.Type.from_parameter_value(default)
            param = Parameter(name, declared_type if default is not None else None, default)
            if not ignore_override and name in self.overrides:
                param = self.overrides[name]
            descriptor.name = name
            if not descriptor.dynamic_typing:
                descriptor.type = int(declared_type)
                if (declared_type != Parameter.Type.NOT_SET
                        and param.type_ not in (declared_type, Parameter.Type.NOT_SET)):
                    raise InvalidParameterTypeException(
                        name, f"expected {_tname(declared_type)}, got {_tname(param.type_)} "
                        f"({param.value!r})")
            else:
                descriptor.type = int(param.type_)
            reason = range_error(param.value, descriptor)
            if reason:
                raise InvalidParameterValueException(name, param.value, reason)
            result = self._run_callbacks([param])
            if not result.successful:
                raise InvalidParameterValueException(name, param.value, result.reason)
            self._descriptors[name] = descriptor
            self._values[name] = param
        for cb in self._post:
            cb([param])
        self._notify([param], [])
        return param

    # --- reading --------------------------------------------------------------------------
    def has(self, name: str) -> bool:
        return name in self._values

    def get(self, name: str) -> Parameter:
        with self._lock:
            if name not in self._values:
                if self.allow_undeclared:
                    return Parameter(name)
                raise ParameterNotDeclaredException(name)
            param = self._values[name]
        if param.type_ == Parameter.Type.NOT_SET and not self._descriptors[name].dynamic_typing \
                and self._descriptors[name].type != 0:
            raise ParameterUninitializedException(name)
        return param

    def names(self) -> list[str]:
        return sorted(self._values)

    def describe(self, name: str) -> Any:
        if name not in self._descriptors:
            raise ParameterNotDeclaredException(name)
        return self._descriptors[name]

    # --- setting --------------------------------------------------------------------------
    def set(self, params: list[Parameter], atomically: bool = False) -> list[Any]:
        """rclpy set_parameters (one result each) or set_parameters_atomically."""
        groups = [params] if atomically else [[p] for p in params]
        results = []
        for group in groups:
            result = self._set_group(group)
            results.append(result)
        return results

    def _set_group(self, params: list[Parameter]) -> Any:
        with self._lock:
            for p in params:
                if p.name not in self._values and not self.allow_undeclared:
                    raise ParameterNotDeclaredException(p.name)
                reason = self._check(p)
                if reason:
                    return SetParametersResult(successful=False, reason=reason)
            result = self._run_callbacks(params)
            if not result.successful:
                return result
            new = [p for p in params if p.name not in self._values]
            for p in params:
                if p.name not in self._values:
                    self._descriptors[p.name] = ParameterDescriptor(name=p.name,
                                                                    type=int(p.type_))
                self._values[p.name] = p
        for cb in self._post:
            cb(list(params))
        self._notify(new, [p for p in params if p not in new])
        return SetParametersResult(successful=True)

    def _notify(self, new: list[Parameter], changed: list[Parameter]) -> None:
        if self.on_event is not None:
            self.on_event(new, changed)

    def _check(self, p: Parameter) -> str | None:
        desc = self._descriptors.get(p.name)
        if desc is None:
            return None
        if desc.read_only:
            return f"parameter '{p.name}' is read-only"
        if not desc.dynamic_typing and desc.type and int(p.type_) != desc.type:
            return (f"wrong parameter type, parameter '{p.name}' is of type "
                    f"{_tname(Parameter.Type(desc.type))}, setting it to "
                    f"{_tname(p.type_)} is not allowed")
        reason = range_error(p.value, desc)
        return f"parameter '{p.name}': {reason}" if reason else None

    def _run_callbacks(self, params: list[Parameter]) -> Any:
        for cb in self._pre:
            params = cb(params) or params
        for cb in self._on_set:
            result = cb(params)
            if not result.successful:
                return result
        return SetParametersResult(successful=True)

    def add_callback(self, kind: str, cb: Callable) -> None:
        {"pre": self._pre, "on_set": self._on_set, "post": self._post}[kind].insert(0, cb)

    def remove_callback(self, kind: str, cb: Callable) -> None:
        {"pre": self._pre, "on_set": self._on_set, "post": self._post}[kind].remove(cb)


def _tname(t: Parameter.Type) -> str:
    return t.name.lower().replace("_array", " array")
