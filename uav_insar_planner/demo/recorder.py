"""The demo's recording (no ROS import): `uav-insar record` as a process of its own beside the
nodes, started before them, ready once it subscribes to every agent's topics, stopped after
them with SIGINT (as Ctrl-C would), so the bag holds the whole mission.
"""
from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from uav_insar_planner.demo.processes import start_process, stop_node

RECORDER_NODE = "uav_insar_recorder"  # ros/tools/bag_recorder.NODE_NAME
# The topics the recorder must have subscribed to before the plan starts the slots: the
# agents' volatile ones (a latched plan would be delivered late anyway).
AGENT_TOPICS = ("uav{k}/achieved_rate", "uav{k}/offload", "uav{k}/pose")


def default_bag_path(now: float | None = None) -> Path:
    """bags/demo_YYYY_MM_DD-HH_MM_SS (UTC) under the current folder, as ros2 bag names them."""
    stamp = time.strftime("%Y_%m_%d-%H_%M_%S", time.gmtime(time.time() if now is None else now))
    return Path("bags") / f"demo_{stamp}"


def start_recorder(path: Path, env: dict[str, str]) -> subprocess.Popen:
    """`uav-insar record path` in `env`; its output stays in its pipe (see stop_recorder)."""
    return start_process([sys.executable, "-m", "uav_insar_planner.cli", "record", str(path)],
                         env)


def recorder_ready(node: Any, uavs: Sequence[int]) -> bool:
    """True once the recorder subscribes to the AGENT_TOPICS of each agent of `uavs` (`node`:
    any rclpy node on the same domain)."""
    return all(any(info.node_name == RECORDER_NODE
                   for info in node.get_subscriptions_info_by_topic("/" + t.format(k=k)))
               for k in uavs for t in AGENT_TOPICS)


def stop_recorder(proc: subprocess.Popen) -> tuple[int, str]:
    """Stop the recorder (SIGINT first) and return its exit code and its last output line
    (`recorded N messages on M topics to PATH`, or its error)."""
    code = stop_node(proc)
    lines = [line.strip() for line in (proc.stdout.read() if proc.stdout else "").splitlines()]
    return code, next((line for line in reversed(lines) if line), "(no output)")
