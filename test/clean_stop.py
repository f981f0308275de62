"""The one check that nodes a test stopped ended cleanly, with their output when they did not.

A node that needs SIGKILL has printed its stacks first (stop_nodes sends STACK_DUMP_SIGNAL
before SIGKILL), so a failed check shows where it hung. An agent hung at its stop a few times
in some thousands of CI stops; a bare `codes == [0, ...]` left only the -9."""
from __future__ import annotations

import subprocess
from collections.abc import Sequence

from uav_insar_planner.demo.processes import stop_nodes

TAIL_CHARS = 6000


def outputs_if_clean(procs: Sequence[subprocess.Popen], codes: Sequence[int]) -> list[str]:
    """Each process's output (its piped stdout, stderr merged), in order; fails, naming the
    exit codes and showing the tail of every unclean process's output, unless all are 0."""
    outs = [proc.stdout.read() if proc.stdout is not None else "" for proc in procs]
    unclean = [f"--- process {i} exited {code}: {' '.join(map(str, proc.args))[:300]}\n"
               f"{out[-TAIL_CHARS:]}"
               for i, (proc, code, out) in enumerate(zip(procs, codes, outs, strict=True))
               if code != 0]
    assert not unclean, f"exit codes {list(codes)}\n" + "\n".join(unclean)
    return outs


def stop_cleanly(procs: Sequence[subprocess.Popen]) -> list[str]:
    """stop_nodes(procs), then `outputs_if_clean`."""
    return outputs_if_clean(procs, stop_nodes(procs))
