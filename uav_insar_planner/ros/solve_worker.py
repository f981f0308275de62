"""Run solves on one background thread so a node's executor never blocks on the solver.

Requests coalesce: while a solve runs, later requests replace each other and only the newest
is solved next (a burst of parameter sets costs at most one extra solve). Results are handed
to `on_result(params, plan, error, reason)` on the worker thread. If `on_result` raises, the
thread ends and `failure` says why, so the node can report itself broken instead of OK.
"""
from __future__ import annotations

import threading
from collections.abc import Callable

from uav_insar_planner.params import Params
from uav_insar_planner.plan import Plan

ResultCallback = Callable[[Params, "Plan | None", "str | None", str], None]


class SolveWorker:
    """One daemon thread calling `solve_fn(params)` for the newest pending request."""

    def __init__(self, solve_fn: Callable[[Params], Plan], on_result: ResultCallback):
        self._solve = solve_fn
        self._on_result = on_result
        self._cond = threading.Condition()
        self._pending: tuple[Params, str] | None = None
        self._busy = False
        self._stopped = False
        self.failure: str | None = None
        self._thread = threading.Thread(target=self._run, name="solve-worker", daemon=True)
        self._thread.start()

    def request(self, params: Params, reason: str) -> bool:
        """Queue a solve; True if it starts now, False if it waits behind a running one."""
        with self._cond:
            idle = not self._busy and self._pending is None
            self._pending = (params, reason)
            self._cond.notify()
            return idle

    def stop(self, timeout: float = 1.0) -> None:
        """Stop taking requests; a solve in progress is abandoned (its thread is a daemon)."""
        with self._cond:
            self._stopped = True
            self._cond.notify()
        self._thread.join(timeout)

    def _run(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self._stopped:
                    self._cond.wait()
                if self._stopped:
                    return
                (params, reason), self._pending = self._pending, None
                self._busy = True
            try:
                plan, error = self._solve(params), None
            except Exception as exc:  # a solver bug must not kill the node; report it instead
                plan, error = None, f"{type(exc).__name__}: {exc}"
            with self._cond:
                self._busy = False
                if self._stopped:
                    return
            try:
                self._on_result(params, plan, error, reason)
            except Exception as exc:  # recorded, never silent: the node turns ERROR
                self.failure = f"{type(exc).__name__}: {exc}"
                return
