"""One I/O loop in a daemon thread, started and stopped the same way by the bridge and by the
simulated vehicle.

A subclass gives `run()` (the loop: it returns once `stopping` is set) and `close()` (frees
what the loop used: its links). `start()` is idempotent; `stop()` sets `stopping`, waits up to
STOP_WAIT_S for the loop and closes. Used as a context manager it runs inside the `with`.
"""
from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from typing import TypeVar

STOP_WAIT_S = 5.0
_Self = TypeVar("_Self", bound="IoThread")


class IoThread(ABC):
    """See the module doc; `thread_name` names the thread (in tracebacks and `ps -T`)."""

    def __init__(self, thread_name: str):
        self._thread_name = thread_name
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def stopping(self) -> bool:
        return self._stop.is_set()

    @property
    def thread_alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    @abstractmethod
    def run(self) -> None:
        """The loop (see the module doc)."""

    @abstractmethod
    def close(self) -> None:
        """Free what the loop used."""

    def start(self) -> None:
        """Start the loop's thread (idempotent)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self.run, name=self._thread_name,
                                            daemon=True)
            self._thread.start()

    def stop(self) -> None:
        """Stop the loop's thread and close."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=STOP_WAIT_S)
            self._thread = None
        self.close()

    def __enter__(self: _Self) -> _Self:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
