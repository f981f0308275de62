"""The six rcl_interfaces parameter services every node serves, so `ros2 param` reaches it.

`~/describe_parameters`, `~/get_parameters`, `~/get_parameter_types`, `~/list_parameters`,
`~/set_parameters` and `~/set_parameters_atomically`, with rclpy's semantics: a request naming
one undeclared parameter gets an empty describe/get/types answer; `set_parameters` sets each
parameter on its own (one result each, through the node's set-parameters callbacks and range
checks); `set_parameters_atomically` sets all or none. Listing follows rclpy's prefix and depth
rules (`list_parameters` below).
"""
from __future__ import annotations

from typing import Any

from .exceptions import ParameterNotDeclaredException, ParameterUninitializedException
from .messages import get_message, msg_type
from .parameter import Parameter, SetParametersResult
from .qos import qos_profile_parameters

ListParametersResult = get_message("rcl_interfaces/msg/ListParametersResult")
_SEP = "."
_DEPTH_RECURSIVE = 0


def list_parameters(names: list[str], prefixes: list[str], depth: int) -> Any:
    """rclpy Node.list_parameters over `names`: a ListParametersResult.

    With no prefixes, the names with fewer than `depth` separators (all of them for depth 0,
    DEPTH_RECURSIVE); with prefixes, each name equal to a prefix or below one with fewer than
    `depth` separators after it (any number for depth 0). `prefixes` of the result holds every
    listed name's namespace (its part before the last '.'), once.
    """
    result = ListParametersResult()

    def shallow(name: str) -> bool:
        return name.count(_SEP) < depth

    recursive = not prefixes and depth == _DEPTH_RECURSIVE
    for name in names:
        if not recursive and not (not prefixes and shallow(name)) and not any(
                name == prefix or (name.startswith(prefix + _SEP) and (
                    depth == _DEPTH_RECURSIVE or shallow(name[len(prefix) + 1:])))
                for prefix in prefixes):
            continue
        result.names.append(name)
        namespace, sep, _ = name.rpartition(_SEP)
        if sep and namespace not in result.prefixes:
            result.prefixes.append(namespace)
    return result


class ParameterService:
    """Creates the six services on `node` (rclpy's qos_profile_parameters, the node's default
    callback group) and answers them from the node's parameter methods."""

    def __init__(self, node: Any) -> None:
        self._node = node
        for srv, service_name, callback in (
                ("DescribeParameters", "describe_parameters", self._describe),
                ("GetParameters", "get_parameters", self._get),
                ("GetParameterTypes", "get_parameter_types", self._get_types),
                ("ListParameters", "list_parameters", self._list),
                ("SetParameters", "set_parameters", self._set),
                ("SetParametersAtomically", "set_parameters_atomically", self._set_atomically)):
            node.create_service(msg_type(f"rcl_interfaces/srv/{srv}"), "~/" + service_name,
                                callback, qos_profile=qos_profile_parameters)

    def _describe(self, request: Any, response: Any) -> Any:
        try:
            response.descriptors = [self._node.describe_parameter(n) for n in request.names]
        except ParameterNotDeclaredException:
            response.descriptors = []
        return response

    def _get(self, request: Any, response: Any) -> Any:
        try:
            response.values = [self._node.get_parameter(n).get_parameter_value()
                               for n in request.names]
        except (ParameterNotDeclaredException, ParameterUninitializedException):
            response.values = []
        return response

    def _get_types(self, request: Any, response: Any) -> Any:
        try:
            response.types = self._node.get_parameter_types(list(request.names))
        except ParameterNotDeclaredException:
            response.types = []
        return response

    def _list(self, request: Any, response: Any) -> Any:
        response.result = self._node.list_parameters(list(request.prefixes), request.depth)
        return response

    def _set(self, request: Any, response: Any) -> Any:
        response.results = [self._set_all([p]) for p in request.parameters]
        return response

    def _set_atomically(self, request: Any, response: Any) -> Any:
        response.result = self._set_all(list(request.parameters))
        return response

    def _set_all(self, msgs: list[Any]) -> Any:
        """Set `msgs` atomically; an undeclared name or an unknown type code is a refusal
        with the reason, not an exception (which would leave the caller without a reply)."""
        try:
            params = [Parameter.from_parameter_msg(m) for m in msgs]
            return self._node.set_parameters_atomically(params)
        except (ParameterNotDeclaredException, ValueError) as exc:
            return SetParametersResult(successful=False, reason=str(exc))
