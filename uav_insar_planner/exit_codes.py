"""The exit codes every command and node of the suite returns, in one table.

    0  done (solved, recorded, stopped by SIGINT / SIGTERM)
    1  failed: a crash or a dead worker thread (a bug, one line naming it, never a zombie
       that looks alive), or a run that did not finish what it set out to do (the demo's
       mission, an echo that heard nothing)
    2  bad input: one line per problem, on stderr, before any work and with nothing written
    3  infeasible: the scenario has no plan (the blocking constraints are named)
"""
from __future__ import annotations

EXIT_OK = 0
EXIT_CRASH = 1
EXIT_BAD_INPUT = 2
EXIT_INFEASIBLE = 3

EXIT_CODES = {EXIT_OK: "done", EXIT_CRASH: "failed (crash, dead worker, not finished)",
              EXIT_BAD_INPUT: "bad input", EXIT_INFEASIBLE: "infeasible"}
