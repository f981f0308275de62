"""A ROS context: parsed global arguments, one DDS participant, shutdown and signals."""
from __future__ import annotations

import itertools
import signal
import sys
import threading
import weakref
from collections.abc import Callable
from typing import Any

from cyclonedds.core import Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Qos
from cyclonedds.topic import Topic

from . import arguments, logging
from .discovery import domain_id_from_env, ensure_domain
from .exceptions import InvalidRosArgumentsError, NotInitializedException
from .graph import GraphAnnouncer, GraphQuery


class Context:
    """Holds the participant all nodes of the context share (one per context, as rmw)."""

    def __init__(self) -> None:
        self._lock = threading.RLock()
        self._ok = False
        self._shutdown_callbacks: list[Callable[[], None]] = []
        self._wakers: weakref.WeakSet[Any] = weakref.WeakSet()
        self._nodes: weakref.WeakSet[Any] = weakref.WeakSet()
        self._topics: dict[str, Topic] = {}
        self._graph_query: GraphQuery | None = None
        self.args = arguments.RosArguments()
        self.participant: DomainParticipant | None = None
        self.graph: GraphAnnouncer | None = None
        self.domain_id = 0
        self.csid_counter = itertools.count(1)

    def init(self, args: list[str] | None = None, domain_id: int | None = None) -> None:
        """Parse `args` (default sys.argv) and join the DDS domain.

        Raises InvalidRosArgumentsError for bad --ros-args, ValueError for a bad
        ROS_DOMAIN_ID or discovery setting, RuntimeError when already initialized.
        """
        with self._lock:
            if self._ok:
                raise RuntimeError("Context.init() must only be called once")
            self.args = arguments.parse(list(sys.argv if args is None else args))
            for name, level in self.args.log_levels.items():
                severity = logging.parse_severity(level)
                if name:
                    logging.get_logger(name).set_level(severity)
                else:
                    logging.set_default_level(severity)
            self.domain_id = domain_id_from_env() if domain_id is None else int(domain_id)
            ensure_domain(self.domain_id)
            self.participant = DomainParticipant(
                self.domain_id, qos=Qos(Policy.Userdata(data=b"enclave=/;")))
            self.graph = GraphAnnouncer(self.participant)
            self._ok = True

    def ok(self) -> bool:
        return self._ok

    def require_ok(self) -> DomainParticipant:
        if not self._ok or self.participant is None:
            raise NotInitializedException("rclpy.init() has not been called")
        return self.participant

    def on_shutdown(self, callback: Callable[[], None]) -> None:
        self._shutdown_callbacks.append(callback)

    def add_waker(self, waker: Any) -> None:
        """Something with .wake() to call on shutdown (an executor)."""
        self._wakers.add(waker)

    def shutdown(self) -> None:
        """Shut down; RuntimeError if already shut down (as rclpy)."""
        if not self._ok:
            raise RuntimeError("Context must be initialized before it can be shutdown")
        self.try_shutdown()

    def try_shutdown(self) -> None:
        """Shut down if not already: wake executors, run callbacks, leave the domain."""
        with self._lock:
            if not self._ok:
                return
            self._ok = False
        for waker in list(self._wakers):
            waker.wake()
        for cb in self._shutdown_callbacks:
            cb()
        for node in list(self._nodes):
            node._release()
        with self._lock:
            participant, self.participant = self.participant, None
            self.graph = None
            self._graph_query = None
            self._topics.clear()
        if participant is not None:
            participant.__del__()  # dds_delete: frees every child entity now, not at GC

    # --- used by nodes --------------------------------------------------------------------
    def topic(self, dds_name: str, msg_cls: type) -> Topic:
        """One Topic entity per DDS topic name in this participant."""
        with self._lock:
            topic = self._topics.get(dds_name)
            if topic is None:
                topic = self._topics[dds_name] = Topic(self.require_ok(), dds_name, msg_cls)
            elif topic.data_type is not msg_cls:
                raise TypeError(f"topic {dds_name!r} already has type "
                                f"{topic.data_type._ros_type}, not {msg_cls._ros_type}")
            return topic

    def add_node(self, node: Any) -> None:
        self._nodes.add(node)
        self.graph_changed()

    def remove_node(self, node: Any) -> None:
        self._nodes.discard(node)
        self.graph_changed()

    def graph_changed(self) -> None:
        """Re-announce the node list (the whole list replaces the previous one)."""
        graph = self.graph
        if graph is not None and self._ok:
            graph.publish(sorted((n._graph_entry() for n in list(self._nodes)),
                                 key=lambda e: (e[0], e[1])))

    def graph_query(self) -> GraphQuery:
        with self._lock:
            if self._graph_query is None:
                self._graph_query = GraphQuery(self.require_ok())
            return self._graph_query


_default_context = Context()


def get_default_context() -> Context:
    return _default_context


def _install_signal_handlers() -> None:
    """SIGINT and SIGTERM shut down every context (spin then raises
    ExternalShutdownException); SIGINT then also raises KeyboardInterrupt, as Python does."""
    if threading.current_thread() is not threading.main_thread():
        return

    def on_signal(signum: int, _frame: object) -> None:
        _default_context.try_shutdown()
        for ctx in list(_extra_contexts):
            ctx.try_shutdown()
        if signum == signal.SIGINT:
            raise KeyboardInterrupt

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)


_extra_contexts: weakref.WeakSet[Context] = weakref.WeakSet()


def init(*, args: list[str] | None = None, context: Context | None = None,
         domain_id: int | None = None) -> None:
    """rclpy.init. Bad --ros-args, ROS_DOMAIN_ID or discovery settings print one error line
    to stderr and exit with code 2."""
    ctx = context or _default_context
    try:
        ctx.init(args, domain_id)
    except (InvalidRosArgumentsError, ValueError) as exc:
        prog = (args or sys.argv or ["ros"])[0].rsplit("/", 1)[-1] or "ros"
        sys.stderr.write(f"{prog}: error: {exc}\n")
        sys.stderr.flush()
        raise SystemExit(2) from None
    if ctx is not _default_context:
        _extra_contexts.add(ctx)
    _install_signal_handlers()
