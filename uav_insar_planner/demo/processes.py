"""Start and stop the suite's executables as `ros2 run` would, launch-free (no ROS import).

Used by `make demo` and the tests: each node is a process of its own, found beside this
Python (what colcon or pip installed) or run with `python -m` on its module; its output is
either echoed line by line with a prefix, as ros2 launch does, or left in its pipe.
"""
from __future__ import annotations

import itertools
import os
import random
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from uav_insar_planner.exit_codes import STACK_DUMP_SIGNAL

STOP_TIMEOUT_S = 5.0
STACK_DUMP_S = 1.0  # for a node's stacks (STACK_DUMP_SIGNAL) before SIGKILL
MODULES = {"planner": "uav_insar_planner.ros.planner", "agent": "uav_insar_sim.agent_node",
           "mavlink_bridge": "uav_insar_planner.ros.mavlink_bridge",
           "uav-insar-vehicle": "uav_insar_sim.vehicle"}
# Held while a caller prints a block (echo, table), so echoed log lines do not cut into it.
PRINT_LOCK = threading.Lock()


def executable(name: str) -> list[str]:
    """How to start console script `name` (a key of MODULES): the one installed beside this
    Python (what `ros2 run` would find), else `python -m` on its module."""
    script = Path(sys.executable).parent / name
    if script.exists():
        return [str(script)]
    found = shutil.which(name)
    if found:
        return [found]
    return [sys.executable, "-m", MODULES[name]]


def ros_env(domain_id: int) -> dict[str, str]:
    """The environment for nodes on a private domain with discovery kept on this host."""
    env = dict(os.environ)
    env.update(ROS_DOMAIN_ID=str(domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               PYTHONUNBUFFERED="1")
    return env


def start_node(name: str, ros_args: Sequence[str], env: dict[str, str],
               echo_prefix: str | None = None) -> subprocess.Popen:
    """Start executable `name` with `--ros-args ros_args` in `env`. With `echo_prefix`, its
    output is printed line by line with that prefix (like ros2 launch); otherwise it is left
    in the pipe `proc.stdout` (stderr merged) for the caller to read."""
    return start_process([*executable(name), "--ros-args", *ros_args], env, echo_prefix)


def start_process(cmd: Sequence[str], env: dict[str, str],
                  echo_prefix: str | None = None) -> subprocess.Popen:
    """Start `cmd` in `env`, its output handled as `start_node` says."""
    proc = subprocess.Popen(list(cmd), env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    if echo_prefix is not None:
        echo(proc, echo_prefix)
    return proc


def echo(proc: subprocess.Popen, prefix: str, *first: str) -> None:
    """Print the lines `first`, then every line of proc's output as it comes, each after
    `prefix` (a thread of its own)."""
    def pump() -> None:
        for line in itertools.chain(first, proc.stdout):
            with PRINT_LOCK:
                print(f"{prefix} {line.rstrip()}", flush=True)

    threading.Thread(target=pump, daemon=True).start()


def start_vehicle(args: Sequence[str], host: str, port: int, env: dict[str, str],
                  echo_prefix: str) -> tuple[subprocess.Popen, int | None]:
    """Start `uav-insar-vehicle ARGS --listen udpin:HOST:PORT` and wait for the line that
    names the port it bound (`vehicle sysid ... on udpin:HOST:PORT`): with `port` 0, the one
    the system chose, taken by nobody else between the choice and the bind (a port found free
    and released first was once taken in between by a busy machine). Returns the process, its
    output echoed (from its start), and that port (None: it ended first; its lines say why)."""
    proc = start_process([*executable("uav-insar-vehicle"), *args, "--listen",
                          f"udpin:{host}:{port}"], env)
    lines, bound = [], None
    while bound is None and (line := proc.stdout.readline()):
        lines.append(line)
        head, sep, tail = line.rstrip().rpartition(f" on udpin:{host}:")
        if sep and head.startswith("vehicle sysid ") and tail.isdigit():
            bound = int(tail)
    echo(proc, echo_prefix, *lines)
    return proc, bound


def stop_node(proc: subprocess.Popen, timeout: float = STOP_TIMEOUT_S) -> int:
    """SIGINT (Ctrl-C), then SIGTERM, each given `timeout`, then SIGKILL (after a stack dump,
    see `stop_nodes`); returns the exit code."""
    return stop_nodes([proc], timeout)[0]


def stop_nodes(procs: Sequence[subprocess.Popen], timeout: float = STOP_TIMEOUT_S,
               before_kill: Callable[[subprocess.Popen], None] | None = None) -> list[int]:
    """`stop_node` for all of `procs` at once (each signal to all, then one shared wait), so
    they shut down in parallel; returns their exit codes in order. Before SIGKILL, what is
    still alive gets STACK_DUMP_SIGNAL and STACK_DUMP_S to print its stacks, then
    `before_kill(proc)` when given (a test's look at its native stacks)."""
    for sig in (signal.SIGINT, signal.SIGTERM, STACK_DUMP_SIGNAL, signal.SIGKILL):
        alive = [p for p in procs if p.poll() is None]
        for proc in alive:
            if sig == signal.SIGKILL and before_kill is not None:
                before_kill(proc)
            proc.send_signal(sig)
        end = time.monotonic() + (STACK_DUMP_S if sig == STACK_DUMP_SIGNAL else timeout)
        for proc in alive:
            try:
                proc.wait(max(0.0, end - time.monotonic()))
            except subprocess.TimeoutExpired:
                continue
    return [p.wait() for p in procs]


def random_domain_id() -> int:
    """A random domain id in 1..101 (well inside Fast DDS's 0..232)."""
    return random.randint(1, 101)
