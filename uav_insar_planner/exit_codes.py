"""The exit codes every command and node of the suite returns, in one table (`EXIT_CODE_TABLE`,
which the documentation's exit-codes page is generated from), and the signal on which a node
prints its stacks."""
from __future__ import annotations

import signal

EXIT_OK = 0
EXIT_CRASH = 1
EXIT_BAD_INPUT = 2
EXIT_INFEASIBLE = 3
EXIT_INTERRUPTED = 130  # the shell's 128 + SIGINT, what Ctrl-C leaves in $?

#: (name, code, meaning) of every exit code.
EXIT_CODE_TABLE: tuple[tuple[str, int, str], ...] = (
    ("EXIT_OK", EXIT_OK, "done: solved, written, recorded, or stopped by SIGINT / SIGTERM"),
    ("EXIT_CRASH", EXIT_CRASH,
     "failed: a crash or a dead worker thread (a bug, one line naming it, never a zombie that "
     "looks alive), or a run that did not finish what it set out to do (the demo's mission; "
     "for `uav-insar echo`, as for `ros2 topic echo`, nothing to echo: no publisher or "
     "message within --timeout, a type it cannot import; for `uav-insar start-missions`, a "
     "vehicle not heard by the instant, when nothing is sent, or one that did not ACCEPT "
     "MISSION_START; for `uav-insar upload-mission`, a vehicle whose mission was not uploaded "
     "and checked back, one stderr line each); or an install without the `planner` extra "
     "the command needs (one line naming what is missing and the pip command)"),
    ("EXIT_BAD_INPUT", EXIT_BAD_INPUT,
     "bad input: one line per problem, on stderr, before any work and with nothing written"),
    ("EXIT_INFEASIBLE", EXIT_INFEASIBLE,
     "infeasible: the scenario has no plan (the blocking constraints are named)"),
    ("EXIT_INTERRUPTED", EXIT_INTERRUPTED,
     "interrupted: a `uav-insar` command that computes (solve, sweep, map, montecarlo, "
     "report, ...) was stopped by SIGINT (Ctrl-C) before it finished; one line, no traceback. "
     "`sweep` and `map` write their files whole at the end or not at all. The nodes, the "
     "demo, `record`, `echo` and `start-missions` take SIGINT as their way to stop (see "
     "EXIT_OK)"),
)
#: A few words per code, for one-line summaries.
EXIT_CODES = {EXIT_OK: "done", EXIT_CRASH: "failed (crash, dead worker, not finished)",
              EXIT_BAD_INPUT: "bad input", EXIT_INFEASIBLE: "infeasible",
              EXIT_INTERRUPTED: "interrupted (Ctrl-C)"}


# A node (ros/run.py) prints every thread's stack on this signal and runs on; the demo and the
# tests send it before SIGKILL (demo/processes.py), so a node that ignored SIGINT and SIGTERM
# leaves in its log where it hung.
STACK_DUMP_SIGNAL = signal.SIGUSR1


class CommandFailed(Exception):
    """A one-line error `str(self)` that ends a command with exit code `code` (the dispatcher
    `uav-insar` prints it after the verb's name)."""

    def __init__(self, message: str, code: int) -> None:
        super().__init__(message)
        self.code = code
