"""Slow flights flown side by side, each checked by its own test. Not a test file.

A test module registers its flight with `@flight(name, group)`: a function of a fresh working
directory and a private ROS domain that flies it and returns what the checks need (or raises
AssertionError naming what did not happen). Its test carries `@pytest.mark.side_by_side(name)`
and asks the session fixture `side_by_side` (conftest) for `result(name)`. The first such
request (or a `start(group)` from a test that runs beside them) starts every flight of that
group whose test was selected, each in a thread of its own; the first result waits for all of
them, so nothing of the group flies on beside the tests that follow. Each test gets its own
flight's result, or its exception re-raised.

Under `make test`'s pytest-xdist workers each worker has a SideBySide of its own: a flight's
module is one of conftest.REAL_TIME_MODULES, which one worker runs, so that each group is
flown once.

Why: an ArduCopter SITL test mostly waits (its EKF takes about 25 s of wall time to use GPS,
then the pass is flown in real time), and takes a small share of a core while it does. Four
such flights started together take about as long as the slowest of them, where one after the
other they took four times as long. Each flight keeps its own processes, ports, working
directory and ROS domain, so none sees another's.
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Flight:
    name: str
    group: str
    fly: Callable[[Path, int], object]
    thread: threading.Thread | None = None
    outcome: list = field(default_factory=list)  # [result] or [None, exception]


_FLIGHTS: dict[str, Flight] = {}


def flight(name: str, group: str) -> Callable:
    """Registers `fly(workdir, domain) -> result` as flight `name` of `group`."""
    def register(fly: Callable[[Path, int], object]) -> Callable[[Path, int], object]:
        assert name not in _FLIGHTS or _FLIGHTS[name].fly.__qualname__ == fly.__qualname__, name
        _FLIGHTS[name] = Flight(name, group, fly)
        return fly

    return register


class SideBySide:
    """The session's flights: started by group on the first request, awaited by name."""

    def __init__(self, selected: set[str], workdir: Callable[[str], Path],
                 domain: Callable[[], int]) -> None:
        self.selected, self.workdir, self.domain = selected, workdir, domain
        self.lock = threading.Lock()

    def _start(self, f: Flight) -> None:
        workdir, domain = self.workdir(f.name), self.domain()

        def run() -> None:
            try:
                f.outcome.append(f.fly(workdir, domain))
            except BaseException as exc:  # handed to the test that checks this flight
                f.outcome[:] = [None, exc]

        f.thread = threading.Thread(target=run, name=f"flight {f.name}")
        f.thread.start()

    def start(self, group: str, also: Flight | None = None) -> None:
        """Starts every selected flight of `group` (and `also`) not yet started: a test that
        runs beside them calls it first, then goes on with its own work."""
        with self.lock:
            for f in _FLIGHTS.values():
                if f.thread is None and f.group == group and (f.name in self.selected
                                                              or f is also):
                    self._start(f)

    def result(self, name: str) -> object:
        """Flight `name`'s result, once every started flight of its group has flown (so none
        flies on beside the tests that follow); its exception if it failed."""
        own = _FLIGHTS[name]
        self.start(own.group, own)
        for f in _FLIGHTS.values():
            if f.group == own.group and f.thread is not None:
                f.thread.join()
        if len(own.outcome) == 2:
            raise own.outcome[1]
        return own.outcome[0]

    def close(self) -> None:
        """Waits for every started flight: none outlives the session (each one stops its own
        processes when it ends)."""
        for f in _FLIGHTS.values():
            if f.thread is not None:
                f.thread.join()
