"""What a lean install leaves out: `install_requires` is only what a UAV's nodes (agent,
mavlink_bridge) import, so a UAV's computer carries no solver, plotting or bag library
(docs/hardware.md). The planner node and the `uav-insar` verbs need setup.py's `planner`
extra; on an install without it they say so in one line, before any work, instead of a
traceback halfway through."""
from __future__ import annotations

import importlib.util
from collections.abc import Sequence

INSTALL_PLANNER = "pip install 'uav_insar_planner[planner]'"
#: What the `planner` extra installs (setup.py PLANNER), by top-level module name.
SOLVER_MODULES = ("scipy", "cvxpy", "clarabel")
PLANNER_MODULES = (*SOLVER_MODULES, "matplotlib", "tqdm", "rosbags", "mcap", "threadpoolctl")


def missing_line(modules: Sequence[str] = PLANNER_MODULES) -> str | None:
    """One line naming those of `modules` this Python cannot import and the command that
    installs them; None when all are there. find_spec only looks: nothing heavy is loaded."""
    gone = [name for name in modules if importlib.util.find_spec(name) is None]
    if not gone:
        return None
    return (f"needs {', '.join(gone)}, which this install leaves out (a UAV's lean install "
            f"has only what agent and mavlink_bridge need); {INSTALL_PLANNER}")
