"""rclpy.task.Future: a thread-safe result holder with done callbacks."""
from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any


class Future:
    """Completed by a service reply (Client.call_async) or by user code."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._event = threading.Event()
        self._result: Any = None
        self._exception: BaseException | None = None
        self._cancelled = False
        self._callbacks: list[Callable[[Future], None]] = []

    def done(self) -> bool:
        return self._event.is_set()

    def cancelled(self) -> bool:
        return self._cancelled

    def cancel(self) -> None:
        with self._lock:
            if self._event.is_set():
                return
            self._cancelled = True
        self._finish()

    def result(self) -> Any:
        """The result, None while not done; re-raises an exception set with set_exception."""
        if self._exception is not None:
            raise self._exception
        return self._result

    def exception(self) -> BaseException | None:
        return self._exception

    def set_result(self, result: Any) -> None:
        with self._lock:
            self._result = result
        self._finish()

    def set_exception(self, exception: BaseException) -> None:
        with self._lock:
            self._exception = exception
        self._finish()

    def add_done_callback(self, callback: Callable[[Future], None]) -> None:
        with self._lock:
            if not self._event.is_set():
                self._callbacks.append(callback)
                return
        callback(self)

    def _finish(self) -> None:
        with self._lock:
            self._event.set()
            callbacks, self._callbacks = self._callbacks, []
        for cb in callbacks:
            cb(self)

    def wait(self, timeout: float | None = None) -> bool:
        """Block until done (only useful while another thread spins)."""
        return self._event.wait(timeout)
