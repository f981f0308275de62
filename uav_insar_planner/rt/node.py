"""rclpy.node.Node on our runtime."""
from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from . import arguments, names
from .callback_groups import CallbackGroup, MutuallyExclusiveCallbackGroup
from .clock import Clock, ClockType
from .context import Context, get_default_context
from .entities import Publisher, Subscription, Timer
from .exceptions import ParameterNotDeclaredException
from .logging import RcutilsLogger
from .messages import get_message
from .parameter import Parameter
from .parameter_service import ParameterService, list_parameters
from .params import ParameterStore
from .qos import (
    QoSProfile,
    as_profile,
    qos_profile_parameter_events,
    qos_profile_services_default,
)


class Node:
    """A named node: publishers, subscriptions, timers, services, clients, parameters.

    Name and namespace honour `-r __node:=` / `-r __ns:=` from the context's and this node's
    arguments; parameter overrides come from `-p` / `--params-file` sections that match the
    node's fully qualified name, then from `parameter_overrides`. Unless
    `start_parameter_services` is False the node serves the six rcl_interfaces parameter
    services (`ros2 param`), see parameter_service.
    """

    def __init__(self, node_name: str, *, context: Context | None = None,
                 cli_args: list[str] | None = None, namespace: str | None = None,
                 use_global_arguments: bool = True, enable_rosout: bool = True,
                 start_parameter_services: bool = True,
                 parameter_overrides: list[Parameter] | None = None,
                 allow_undeclared_parameters: bool = False,
                 automatically_declare_parameters_from_overrides: bool = False) -> None:
        self.context = context or get_default_context()
        self.context.require_ok()
        arg_sets = [self.context.args] if use_global_arguments else []
        if cli_args:
            arg_sets.append(arguments.parse(["node", "--ros-args", *cli_args]
                                            if "--ros-args" not in cli_args
                                            else ["node", *cli_args]))
        for args in arg_sets:
            node_name = args.remap_for(node_name, "__node") or node_name
        ns = namespace or ""
        for args in arg_sets:
            ns = args.remap_for(node_name, "__ns") or ns
        names.validate_node_name(node_name)
        self._name = node_name
        self._namespace = names.normalize_namespace(ns)
        self._remaps = [r for args in arg_sets for r in args.topic_remaps(node_name)]
        self._lock = threading.RLock()
        self._logger = RcutilsLogger(
            ".".join([*self._namespace.strip("/").split("/"), node_name]).lstrip("."))
        self._clock = Clock(clock_type=ClockType.ROS_TIME)
        self.default_callback_group = MutuallyExclusiveCallbackGroup()
        self.publishers: list[Publisher] = []
        self.subscriptions: list[Subscription] = []
        self.timers: list[Timer] = []
        self.services: list[Any] = []
        self.clients: list[Any] = []
        self._executor: Any = None
        overrides: dict[str, Parameter] = {}
        for args in arg_sets:
            for name, value in args.overrides_for(self.get_fully_qualified_name()).items():
                overrides[name] = Parameter(name, value=value)
        for p in parameter_overrides or []:
            overrides[p.name] = p
        self._params = ParameterStore(overrides, allow_undeclared_parameters)
        # Created before use_sim_time is declared so that, as in rclpy, every declaration and
        # change of this node's parameters is announced on /parameter_events.
        self._parameter_events = self.create_publisher(
            get_message("rcl_interfaces/msg/ParameterEvent"), "/parameter_events",
            qos_profile_parameter_events)
        self._params.on_event = self._publish_parameter_event
        self.declare_parameter("use_sim_time", False)
        if automatically_declare_parameters_from_overrides:
            for name, p in overrides.items():
                if not self._params.has(name):
                    self._params.declare(name, p.value)
        self.context.add_node(self)
        if start_parameter_services:
            ParameterService(self)

    # --- identity -------------------------------------------------------------------------
    def get_name(self) -> str:
        return self._name

    def get_namespace(self) -> str:
        return self._namespace

    def get_fully_qualified_name(self) -> str:
        return self._namespace.rstrip("/") + "/" + self._name

    def get_logger(self) -> RcutilsLogger:
        return self._logger

    def get_clock(self) -> Clock:
        return self._clock

    @property
    def executor(self) -> Any:
        return self._executor

    @executor.setter
    def executor(self, executor: Any) -> None:
        if self._executor is not None and self._executor is not executor:
            self._executor.remove_node(self)
        self._executor = executor
        if executor is not None:
            executor.add_node(self)

    def _wake(self) -> None:
        if self._executor is not None:
            self._executor.wake()

    def resolve_topic_name(self, topic: str, *, only_expand: bool = False) -> str:
        fq = names.resolve(topic, self._namespace, self._name)
        if only_expand:
            return fq
        for frm, to in self._remaps:
            if names.resolve(frm, self._namespace, self._name) == fq:
                fq = names.resolve(to, self._namespace, self._name)
        return fq

    # --- entities -------------------------------------------------------------------------
    def _added(self, collection: list, entity: Any) -> Any:
        with self._lock:
            collection.append(entity)
        self.context.graph_changed()
        self._wake()
        return entity

    def create_publisher(self, msg_type: type, topic: str, qos_profile: QoSProfile | int, *,
                         callback_group: CallbackGroup | None = None,
                         **_options: Any) -> Publisher:
        pub = Publisher(self, msg_type, self.resolve_topic_name(topic), as_profile(qos_profile),
                        callback_group or self.default_callback_group)
        return self._added(self.publishers, pub)

    def create_subscription(self, msg_type: type, topic: str, callback: Callable[[Any], None],
                            qos_profile: QoSProfile | int, *,
                            callback_group: CallbackGroup | None = None,
                            **_options: Any) -> Subscription:
        sub = Subscription(self, msg_type, self.resolve_topic_name(topic), callback,
                           as_profile(qos_profile),
                           callback_group or self.default_callback_group)
        return self._added(self.subscriptions, sub)

    def create_timer(self, timer_period_sec: float, callback: Callable[[], None] | None,
                     callback_group: CallbackGroup | None = None, clock: Clock | None = None,
                     autostart: bool = True) -> Timer:
        timer = Timer(callback, timer_period_sec, callback_group or self.default_callback_group,
                      autostart)
        timer._on_change = self._wake
        return self._added(self.timers, timer)

    def create_service(self, srv_type: type, srv_name: str, callback: Callable[[Any, Any], Any],
                       *, qos_profile: QoSProfile = qos_profile_services_default,
                       callback_group: CallbackGroup | None = None) -> Any:
        from .service import Service
        srv = Service(self, srv_type, self.resolve_topic_name(srv_name), callback, qos_profile,
                      callback_group or self.default_callback_group)
        return self._added(self.services, srv)

    def create_client(self, srv_type: type, srv_name: str, *,
                      qos_profile: QoSProfile = qos_profile_services_default,
                      callback_group: CallbackGroup | None = None) -> Any:
        from .service import Client
        cli = Client(self, srv_type, self.resolve_topic_name(srv_name), qos_profile,
                     callback_group or self.default_callback_group)
        return self._added(self.clients, cli)

    def _destroy(self, collection: list, entity: Any) -> bool:
        with self._lock:
            if entity not in collection:
                return False
            collection.remove(entity)
        entity.destroy()
        self.context.graph_changed()
        self._wake()
        return True

    def destroy_publisher(self, publisher: Publisher) -> bool:
        return self._destroy(self.publishers, publisher)

    def destroy_subscription(self, subscription: Subscription) -> bool:
        return self._destroy(self.subscriptions, subscription)

    def destroy_timer(self, timer: Timer) -> bool:
        return self._destroy(self.timers, timer)

    def destroy_service(self, service: Any) -> bool:
        return self._destroy(self.services, service)

    def destroy_client(self, client: Any) -> bool:
        return self._destroy(self.clients, client)

    def _release(self) -> None:
        """Forget every entity (the participant is going away)."""
        with self._lock:
            for coll in (self.publishers, self.subscriptions, self.timers, self.services,
                         self.clients):
                coll.clear()

    def destroy_node(self) -> None:
        """Destroy every entity and leave the graph."""
        if self._executor is not None:
            self._executor.remove_node(self)
        if self.context.ok():
            for coll in (self.publishers, self.subscriptions, self.timers, self.services,
                         self.clients):
                for entity in list(coll):
                    entity.destroy()
        self._release()
        self.context.remove_node(self)

    def _graph_entry(self) -> tuple[str, str, list[bytes], list[bytes]]:
        with self._lock:
            readers = [s.gid for s in self.subscriptions]
            writers = [p.gid for p in self.publishers]
            for cs in (*self.services, *self.clients):
                readers.append(cs.reader_gid)
                writers.append(cs.writer_gid)
        return self._namespace, self._name, readers, writers

    # --- graph queries --------------------------------------------------------------------
    def count_publishers(self, topic_name: str) -> int:
        dds = "rt" + self.resolve_topic_name(topic_name)
        return sum(1 for e in self.context.graph_query().publications() if e.topic_name == dds)

    def count_subscribers(self, topic_name: str) -> int:
        dds = "rt" + self.resolve_topic_name(topic_name)
        return sum(1 for e in self.context.graph_query().subscriptions() if e.topic_name == dds)

    def get_topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        from .messages import ros_typename
        found: dict[str, set[str]] = {}
        q = self.context.graph_query()
        for e in (*q.publications(), *q.subscriptions()):
            if e.topic_name.startswith("rt/"):
                try:
                    found.setdefault(e.topic_name[2:], set()).add(ros_typename(e.type_name))
                except ValueError:
                    continue
        return sorted((k, sorted(v)) for k, v in found.items())

    # --- parameters -----------------------------------------------------------------------
    def declare_parameter(self, name: str, value: Any = None, descriptor: Any = None,
                          ignore_override: bool = False) -> Parameter:
        return self._params.declare(name, value, descriptor, ignore_override)

    def declare_parameters(self, namespace: str, parameters: list[tuple],
                           ignore_override: bool = False) -> list[Parameter]:
        out = []
        for item in parameters:
            name = f"{namespace}.{item[0]}" if namespace else item[0]
            value = item[1] if len(item) > 1 else None
            descriptor = item[2] if len(item) > 2 else None
            out.append(self._params.declare(name, value, descriptor, ignore_override))
        return out

    def undeclare_parameter(self, name: str) -> None:
        raise NotImplementedError("undeclare_parameter is not supported by this runtime")

    def has_parameter(self, name: str) -> bool:
        return self._params.has(name)

    def get_parameter(self, name: str) -> Parameter:
        return self._params.get(name)

    def get_parameters(self, names_: list[str]) -> list[Parameter]:
        return [self._params.get(n) for n in names_]

    def get_parameter_or(self, name: str, alternative_value: Parameter | None = None) -> Parameter:
        if not self._params.has(name):
            return alternative_value if alternative_value is not None else Parameter(name)
        return self._params.get(name)

    def get_parameters_by_prefix(self, prefix: str) -> dict[str, Parameter]:
        pre = prefix + "." if prefix else ""
        return {n[len(pre):]: self._params.get(n) for n in self._params.names()
                if n.startswith(pre)}

    def set_parameters(self, parameter_list: list[Parameter]) -> list[Any]:
        return self._params.set(parameter_list)

    def set_parameters_atomically(self, parameter_list: list[Parameter]) -> Any:
        return self._params.set(parameter_list, atomically=True)[0]

    def _publish_parameter_event(self, new: list[Parameter], changed: list[Parameter]) -> None:
        msg = self._parameter_events.msg_type(
            stamp=self._clock.now().to_msg(), node=self.get_fully_qualified_name(),
            new_parameters=[p.to_parameter_msg() for p in new],
            changed_parameters=[p.to_parameter_msg() for p in changed])
        self._parameter_events.publish(msg)

    def get_parameter_type(self, name: str) -> int:
        """The parameter's ParameterType code; ParameterNotDeclaredException if undeclared."""
        if not self._params.has(name):
            raise ParameterNotDeclaredException(name)
        return int(self._params.get(name).type_)

    def get_parameter_types(self, names_: list[str]) -> list[int]:
        return [self.get_parameter_type(n) for n in names_]

    def list_parameters(self, prefixes: list[str], depth: int) -> Any:
        """rclpy Node.list_parameters: a ListParametersResult (see parameter_service)."""
        if not all(isinstance(p, str) for p in prefixes):
            raise TypeError("all prefixes must be instances of type str")
        if depth < 0:
            raise ValueError("the depth must be greater than or equal to zero")
        return list_parameters(self._params.names(), prefixes, depth)

    def describe_parameter(self, name: str) -> Any:
        return self._params.describe(name)

    def describe_parameters(self, names_: list[str]) -> list[Any]:
        return [self._params.describe(n) for n in names_]

    def add_on_set_parameters_callback(self, callback: Callable) -> None:
        self._params.add_callback("on_set", callback)

    def remove_on_set_parameters_callback(self, callback: Callable) -> None:
        self._params.remove_callback("on_set", callback)

    def add_pre_set_parameters_callback(self, callback: Callable) -> None:
        self._params.add_callback("pre", callback)

    def add_post_set_parameters_callback(self, callback: Callable) -> None:
        self._params.add_callback("post", callback)

