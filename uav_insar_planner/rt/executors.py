"""SingleThreadedExecutor and MultiThreadedExecutor over a Cyclone WaitSet.

One wait covers every reader of the executor's nodes (via ReadConditions), a guard condition
(new entities, futures, shutdown) and the nearest timer deadline. Each spin_once runs at most
one callback (single-threaded) or hands one to the pool (multi-threaded), timers first, then
subscriptions, services and clients, rotating so that a busy reader cannot starve others.
"""
from __future__ import annotations

import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from cyclonedds.core import GuardCondition, WaitSet

from .context import Context, get_default_context
from .exceptions import ExternalShutdownException
from .task import Future

# A blocked wait cannot run Python signal handlers; waking this often bounds Ctrl-C latency.
_MAX_WAIT_NS = 100_000_000


class Executor:
    """Base executor: node bookkeeping and the wait for the next ready callback."""

    def __init__(self, *, context: Context | None = None) -> None:
        self._context = context or get_default_context()
        self._nodes: list[Any] = []
        self._lock = threading.RLock()
        self._guard: GuardCondition | None = None
        self._waitset: WaitSet | None = None
        self._attached: set[int] = set()
        self._rotation = 0
        self._is_shutdown = False
        self._context.add_waker(self)

    @property
    def context(self) -> Context:
        return self._context

    def add_node(self, node: Any) -> bool:
        with self._lock:
            if node in self._nodes:
                return False
            self._nodes.append(node)
        previous = node._executor
        if previous is not None and previous is not self:
            previous.remove_node(node)
        node._executor = self
        self.wake()
        return True

    def remove_node(self, node: Any) -> None:
        with self._lock:
            if node in self._nodes:
                self._nodes.remove(node)
                node._executor = None
        self.wake()

    def get_nodes(self) -> list[Any]:
        with self._lock:
            return list(self._nodes)

    def wake(self) -> None:
        guard = self._guard
        if guard is not None:
            try:
                guard.set(True)
            except Exception:  # noqa: BLE001 - the participant may be gone at shutdown
                pass

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        self._is_shutdown = True
        with self._lock:
            for node in self._nodes:
                node._executor = None
            self._nodes.clear()
        self.wake()
        return True

    # --- spinning -------------------------------------------------------------------------
    def spin(self) -> None:
        """Run callbacks until the context or this executor is shut down."""
        while self._context.ok() and not self._is_shutdown:
            self.spin_once()

    def spin_once(self, timeout_sec: float | None = None) -> None:
        raise NotImplementedError

    def spin_until_future_complete(self, future: Future,
                                   timeout_sec: float | None = None) -> None:
        """Spin until `future` is done, or until timeout_sec (None or < 0: no timeout)."""
        future.add_done_callback(lambda _f: self.wake())
        if timeout_sec is None or timeout_sec < 0:
            while self._context.ok() and not future.done() and not self._is_shutdown:
                self.spin_once()
            return
        end = time.monotonic() + timeout_sec
        while self._context.ok() and not future.done() and not self._is_shutdown:
            remaining = end - time.monotonic()
            if remaining <= 0:
                return
            self.spin_once(timeout_sec=remaining)

    def spin_once_until_future_complete(self, future: Future,
                                        timeout_sec: float | None = None) -> None:
        future.add_done_callback(lambda _f: self.wake())
        self.spin_once(timeout_sec)

    # --- waiting --------------------------------------------------------------------------
    def _entities(self) -> tuple[list[Any], list[Any]]:
        timers, waitables = [], []
        with self._lock:
            nodes = list(self._nodes)
        for node in nodes:
            with node._lock:
                timers += node.timers
                waitables += [*node.subscriptions, *node.services, *node.clients]
        return timers, waitables

    def _sync_waitset(self, waitables: list[Any]) -> None:
        participant = self._context.require_ok()
        if self._waitset is None:
            self._waitset = WaitSet(participant)
            self._guard = GuardCondition(participant)
            self._waitset.attach(self._guard)
        wanted = {id(w.condition): w.condition for w in waitables}
        for key in self._attached - wanted.keys():
            self._attached.discard(key)  # destroyed conditions detach themselves
        for key, cond in wanted.items():
            if key not in self._attached:
                self._waitset.attach(cond)
                self._attached.add(key)

    def _wait_for_ready(self, timeout_sec: float | None, usable: Any) -> tuple[Any, Any] | None:
        """Wait for the next (entity, data) whose callback group accepts it.

        `usable(entity)` says whether the entity may run now. Raises ExternalShutdownException
        when the context is shut down; returns None on timeout.
        """
        end = None if timeout_sec is None or timeout_sec < 0 else (
            time.monotonic_ns() + int(timeout_sec * 1e9))
        while True:
            if not self._context.ok():
                raise ExternalShutdownException()
            if self._is_shutdown:
                return None
            timers, waitables = self._entities()
            now = time.monotonic_ns()
            due = [t for t in timers if t.is_ready() and usable(t)]
            if due:
                return min(due, key=lambda t: t.next_call_ns()), None
            blocked = False
            n = len(waitables)
            for i in range(n):
                w = waitables[(self._rotation + i) % n]
                if not usable(w):
                    blocked = True
                    continue
                data = w._take()
                if data is not None:
                    self._rotation = (self._rotation + i + 1) % max(n, 1)
                    return w, data
            wait_ns = _MAX_WAIT_NS
            for t in timers:
                nxt = t.next_call_ns()
                if nxt is not None:
                    wait_ns = min(wait_ns, max(0, nxt - now))
            if end is not None:
                if now >= end:
                    return None
                wait_ns = min(wait_ns, end - now)
            if blocked:
                wait_ns = min(wait_ns, 1_000_000)  # a busy group frees up soon; poll gently
            try:
                self._sync_waitset(waitables)
                if blocked:
                    time.sleep(wait_ns / 1e9)
                else:
                    self._waitset.wait(max(wait_ns, 0))
                self._guard.take()
            except Exception:
                if not self._context.ok():
                    raise ExternalShutdownException() from None
                raise


class SingleThreadedExecutor(Executor):
    """Runs callbacks in the spinning thread, one per spin_once."""

    def spin_once(self, timeout_sec: float | None = None) -> None:
        ready = self._wait_for_ready(timeout_sec, lambda _e: True)
        if ready is not None:
            entity, data = ready
            entity._execute(data)


class MultiThreadedExecutor(Executor):
    """Runs callbacks on a thread pool; callback groups decide what may overlap (a node's
    default group is mutually exclusive, so one node's callbacks never overlap)."""

    def __init__(self, num_threads: int | None = None, *, context: Context | None = None) -> None:
        super().__init__(context=context)
        self._pool = ThreadPoolExecutor(max_workers=num_threads or os.cpu_count() or 2)
        self._running: set[int] = set()
        self._run_lock = threading.Lock()

    def _usable(self, entity: Any) -> bool:
        with self._run_lock:
            return id(entity) not in self._running and entity.callback_group.can_execute()

    def spin_once(self, timeout_sec: float | None = None) -> None:
        ready = self._wait_for_ready(timeout_sec, self._usable)
        if ready is None:
            return
        entity, data = ready
        group = entity.callback_group
        with self._run_lock:
            if not group.beginning_execution():
                return
            self._running.add(id(entity))

        def run() -> None:
            try:
                entity._execute(data)
            finally:
                group.ending_execution()
                with self._run_lock:
                    self._running.discard(id(entity))
                self.wake()

        self._pool.submit(run)

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        super().shutdown(timeout_sec)
        self._pool.shutdown(wait=True)
        return True
