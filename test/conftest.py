"""Shared fixtures: a private ROS domain per test and real child processes on it."""
from __future__ import annotations

import itertools
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parent.parent
CHILD = Path(__file__).resolve().parent / "rt_child.py"
_counter = itertools.count()


def _next_domain() -> int:
    # Domains 1..101 keep Cyclone's discovery ports below Linux's ephemeral range; pid spreads
    # parallel pytest processes, the counter separates tests within one.
    return 1 + (os.getpid() * 7 + next(_counter)) % 101


@pytest.fixture
def ros_domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A domain id for this test alone, exported as ROS_DOMAIN_ID, with our runtime forced
    and the default discovery settings (no CYCLONEDDS_URI, no discovery range)."""
    domain = _next_domain()
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("UAV_INSAR_RUNTIME", "embedded")
    for var in ("CYCLONEDDS_URI", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS"):
        monkeypatch.delenv(var, raising=False)
    return domain


@pytest.fixture
def another_domain(ros_domain: int) -> int:
    """A second private domain, different from ros_domain."""
    domain = _next_domain()
    while domain == ros_domain:
        domain = _next_domain()
    return domain


class Children:
    """Starts Python child processes with the test's environment; kills leftovers."""

    def __init__(self) -> None:
        self.procs: list[subprocess.Popen] = []

    def start(self, *args: str, script: Path | None = None,
              module: str | None = None) -> subprocess.Popen:
        env = dict(os.environ, PYTHONPATH=str(REPO), PYTHONUNBUFFERED="1")
        cmd = [sys.executable] + (["-m", module] if module else [str(script or CHILD)])
        proc = subprocess.Popen(cmd + list(args), env=env, cwd=REPO, text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self.procs.append(proc)
        return proc

    def run(self, *args: str, timeout: float = 20, **kw: object) -> subprocess.CompletedProcess:
        proc = self.start(*args, **kw)
        out, err = proc.communicate(timeout=timeout)
        return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)

    def close(self) -> None:
        for proc in self.procs:
            if proc.poll() is None:
                proc.kill()
            proc.communicate(timeout=10)


@pytest.fixture
def children(ros_domain: int):
    kids = Children()
    yield kids
    kids.close()


@pytest.fixture
def rt_context(ros_domain: int):
    """An initialized in-process context of our runtime on the test's domain."""
    from uav_insar_planner import rt

    ctx = rt.Context()
    rt.init(args=["test"], context=ctx, domain_id=ros_domain)
    yield ctx
    ctx.try_shutdown()


def spin_until(executor: Any, done: Callable[[], Any], timeout: float) -> bool:
    """Spin `executor` in 50 ms steps until `done()` is truthy or `timeout` s have passed."""
    end = time.monotonic() + timeout
    while not done() and time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)
    return bool(done())
