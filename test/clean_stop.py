"""The one check that nodes a test stopped ended cleanly, with their output when they did not.

A node that needs SIGKILL has printed its stacks first (stop_nodes sends STACK_DUMP_SIGNAL
before SIGKILL), so a failed check shows where it hung. An agent hung at its stop a few times
in some thousands of CI stops; a bare `codes == [0, ...]` left only the -9."""
from __future__ import annotations

import shutil
import subprocess
from collections.abc import Sequence

from uav_insar_planner.demo.processes import stop_nodes

TAIL_CHARS = 6000
GDB_TIMEOUT_S = 60.0


def native_stacks(proc: subprocess.Popen) -> None:
    """Print every thread's native stack of `proc`, about to be SIGKILLed, with gdb when
    there is one. A node hung inside the middleware holds the GIL there, where its Python
    stacks end (rclpy's destroy_node, once)."""
    gdb = shutil.which("gdb")
    if gdb is None:
        return
    try:
        out = subprocess.run([gdb, "-p", str(proc.pid), "-batch",
                              "-ex", "set print frame-arguments none",
                              "-ex", "thread apply all bt"],
                             capture_output=True, text=True, timeout=GDB_TIMEOUT_S).stdout
    except subprocess.TimeoutExpired:
        out = "(gdb did not finish)"
    print(f"--- native stacks of {_head(proc)}\n{out}")


def _head(proc: subprocess.Popen) -> str:
    return " ".join(map(str, proc.args))[:300]


def stop_and_read(procs: Sequence[subprocess.Popen]) -> tuple[list[int], list[str]]:
    """stop_nodes(procs), then each one's output (its piped stdout, stderr merged). The tail of
    every output is printed too: pytest shows it when the test fails, whatever failed."""
    codes = stop_nodes(procs, before_kill=native_stacks)
    outs = [proc.stdout.read() if proc.stdout is not None else "" for proc in procs]
    for proc, code, out in zip(procs, codes, outs, strict=True):
        print(f"--- exited {code}: {_head(proc)}\n{out[-TAIL_CHARS:]}")
    return codes, outs


def assert_clean(procs: Sequence[subprocess.Popen], codes: Sequence[int],
                 outs: Sequence[str]) -> None:
    """Fails, naming the exit codes and showing the tail of every unclean process's output,
    unless every code is 0."""
    unclean = [f"--- process {i} exited {code}: {_head(proc)}\n{out[-TAIL_CHARS:]}"
               for i, (proc, code, out) in enumerate(zip(procs, codes, outs, strict=True))
               if code != 0]
    assert not unclean, f"exit codes {list(codes)}\n" + "\n".join(unclean)


def stop_cleanly(procs: Sequence[subprocess.Popen]) -> list[str]:
    """`stop_and_read`, then `assert_clean`; returns the outputs."""
    codes, outs = stop_and_read(procs)
    assert_clean(procs, codes, outs)
    return outs
