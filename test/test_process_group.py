"""process_group.run leaves nothing behind: a grandchild that outlives its parent is killed
with the group, on a normal exit and on a timeout."""
from __future__ import annotations

import subprocess
import time

import process_group
import pytest

# the parent prints its background child's pid and exits; the child sleeps on, off the pipes
SPAWN = "sleep 300 >/dev/null 2>&1 & echo $!"


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_a_grandchild_dies_with_its_group_on_exit():
    done = process_group.run(["sh", "-c", SPAWN], capture_output=True,
                             text=True, timeout=10)
    pid = int(done.stdout.split()[0])
    deadline = time.monotonic() + 5
    while _alive(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert done.returncode == 0 and not _alive(pid)


def test_a_timeout_kills_the_whole_group(tmp_path):
    pid_file = tmp_path / "pid"
    started = time.monotonic()
    with pytest.raises(subprocess.TimeoutExpired):
        process_group.run(["sh", "-c", f"sleep 300 & echo $! > {pid_file}; wait"], timeout=1)
    assert time.monotonic() - started < 60  # not held until the sleep ends by itself
    pid = int(pid_file.read_text())
    deadline = time.monotonic() + 5
    while _alive(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(pid)
