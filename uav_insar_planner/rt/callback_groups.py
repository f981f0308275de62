"""rclpy.callback_groups: which callbacks may run at the same time (MultiThreadedExecutor)."""
from __future__ import annotations

import threading


class CallbackGroup:
    """Base: tracks how many callbacks of the group are running."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._running = 0

    def can_execute(self) -> bool:
        return True

    def beginning_execution(self) -> bool:
        with self._lock:
            if not self._allowed():
                return False
            self._running += 1
            return True

    def ending_execution(self) -> None:
        with self._lock:
            self._running -= 1

    def _allowed(self) -> bool:
        return True


class MutuallyExclusiveCallbackGroup(CallbackGroup):
    """One callback of the group at a time (the default group of every node)."""

    def can_execute(self) -> bool:
        return self._running == 0

    def _allowed(self) -> bool:
        return self._running == 0


class ReentrantCallbackGroup(CallbackGroup):
    """Callbacks of the group may run in parallel."""
