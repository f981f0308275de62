"""The one way the tests run and stop child processes: each in a process group of its own,
and the whole group killed at the end, so nothing a child started outlives its test."""
from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Sequence


def kill_group(proc: subprocess.Popen, sig: int = signal.SIGKILL) -> None:
    """Sends `sig` to proc's process group, leader gone or not, and reaps the leader."""
    try:
        os.killpg(proc.pid, sig)
    except ProcessLookupError:
        pass  # the group is empty: everything in it has ended
    if sig == signal.SIGKILL:
        proc.wait(timeout=10)


# A demo's own stop: each node's SIGINT, SIGTERM and stack dump (processes.stop_nodes).
STOP_GRACE_S = 15.0


def run(args: Sequence[str], *, timeout: float | None = None, input: str | bytes | None = None,
        capture_output: bool = False, check: bool = False,
        **popen: object) -> subprocess.CompletedProcess:
    """subprocess.run in a new session: on exit, timeout or error the group is killed, after
    a Ctrl-C (`interrupt_group`) when the process still runs: a demo timed out stops the nodes
    it started in sessions of their own, which a SIGKILL to its group alone left running."""
    if capture_output:
        popen.setdefault("stdout", subprocess.PIPE)
        popen.setdefault("stderr", subprocess.PIPE)
    if input is not None:
        popen["stdin"] = subprocess.PIPE
    with subprocess.Popen(args, start_new_session=True, **popen) as proc:
        try:
            out, err = proc.communicate(input, timeout=timeout)
        finally:
            interrupt_group(proc, STOP_GRACE_S)
    done = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
    if check:
        done.check_returncode()
    return done


def interrupt_group(proc: subprocess.Popen, grace: float = 8.0) -> None:
    """Ctrl-C to proc's group, as a terminal would; SIGKILL to the group after `grace` s."""
    if proc.poll() is None:
        kill_group(proc, signal.SIGINT)
        try:
            proc.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            pass
    kill_group(proc)
