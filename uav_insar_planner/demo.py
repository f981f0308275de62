"""`make demo` / `python -m uav_insar_planner.demo`: one whole mission, four processes.

Starts the `planner` and three `agent` executables as separate processes, as `ros2 run` would,
on a private ROS_DOMAIN_ID with discovery kept on this host; this process watches the topics
like `ros2 topic echo` would. It prints /formation, each UAV's achieved rate per slot (a
compact table), and a summary; then stops every process with SIGINT (as Ctrl-C would).

Exit code 0 when every flown UAV reported every slot; 1 when something did not happen in time
(no plan, a process died, slots missing); 2 for bad options.
"""
from __future__ import annotations

import argparse
import math
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
from typing import Any

from uav_insar_planner.nodes.planner_report import ERROR, PLAN_STATUS_NAME
from uav_insar_planner.params import Params

REPO_CONFIG = Path(__file__).resolve().parents[1] / "config" / "params.yaml"
STOP_TIMEOUT_S = 5.0
# Held while the demo prints a block (echo, table), so node log lines do not cut into it.
PRINT_LOCK = threading.Lock()


# --- processes ---------------------------------------------------------------------------
def executable(name: str) -> list[str]:
    """How to start console script `name` (`planner`, `agent`): the one installed beside this
    Python (what `ros2 run` would find), else `python -m` on its module."""
    script = Path(sys.executable).parent / name
    if script.exists():
        return [str(script)]
    found = shutil.which(name)
    if found:
        return [found]
    module = {"planner": "uav_insar_planner.nodes.planner", "agent": "uav_insar_sim.agent_node"}
    return [sys.executable, "-m", module[name]]


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
    proc = subprocess.Popen([*executable(name), "--ros-args", *ros_args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    if echo_prefix is not None:
        def pump() -> None:
            for line in proc.stdout:
                with PRINT_LOCK:
                    print(f"{echo_prefix} {line.rstrip()}", flush=True)

        threading.Thread(target=pump, daemon=True).start()
    return proc


def stop_node(proc: subprocess.Popen, timeout: float = STOP_TIMEOUT_S) -> int:
    """SIGINT (Ctrl-C), then SIGTERM, then SIGKILL, each given `timeout`; returns the exit code."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
        if proc.poll() is not None:
            break
        proc.send_signal(sig)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            continue
    return proc.wait()


def free_domain_id() -> int:
    """A random domain id in 1..101 (its discovery ports stay below the ephemeral range)."""
    return random.randint(1, 101)


# --- watching ----------------------------------------------------------------------------
def message_yaml(msg: Any) -> str:
    """A message as `ros2 topic echo` prints it."""
    from uav_insar_planner.seam import USING_RCLPY

    if USING_RCLPY:
        from rosidl_runtime_py.convert import message_to_yaml

        return message_to_yaml(msg)
    from uav_insar_planner.echo import to_yaml

    return to_yaml(msg)


class Watcher:
    """A node that records /formation, /formation/power, rates and diagnostics."""

    def __init__(self, node: Any) -> None:
        from uav_insar_planner.nodes.planner import LATCHED
        from uav_insar_planner.seam import msg_type

        self.formation = None
        self.power = None
        self.rates: dict[int, list[float]] = {0: [], 1: [], 2: []}
        self.diagnostics = None
        node.create_subscription(msg_type("geometry_msgs/msg/PoseArray"), "formation",
                                 self._on_formation, LATCHED)
        node.create_subscription(msg_type("std_msgs/msg/Float64MultiArray"), "formation/power",
                                 self._on_power, LATCHED)
        node.create_subscription(msg_type("diagnostic_msgs/msg/DiagnosticArray"), "/diagnostics",
                                 self._on_diagnostics, 10)
        for k in range(3):
            node.create_subscription(msg_type("std_msgs/msg/Float64"), f"uav{k}/achieved_rate",
                                     lambda msg, k=k: self.rates[k].append(msg.data), 100)

    def _on_formation(self, msg) -> None:
        self.formation = msg

    def _on_power(self, msg) -> None:
        self.power = msg

    def _on_diagnostics(self, msg) -> None:
        self.diagnostics = msg

    def plan_failed(self) -> bool:
        """True once /diagnostics reports the plan as ERROR (infeasible or solve failed)."""
        return self.diagnostics is not None and any(
            s.name == PLAN_STATUS_NAME and s.message and level_of(s) == ERROR
            for s in self.diagnostics.status)

    @property
    def num_slots(self) -> int:
        return self.power.layout.dim[1].size if self.power is not None else 0

    def flown(self) -> list[int]:
        """UAVs the plan flies (finite target)."""
        return [k for k, p in enumerate(self.formation.poses) if math.isfinite(p.position.x)]


def level_of(status: Any) -> int:
    """DiagnosticStatus.level as an int (rclpy gives a 1-byte bytes, our runtime an int)."""
    level = status.level
    return level[0] if isinstance(level, (bytes, bytearray)) else int(level)


def spin_until(executor: Any, done: Callable[[], Any], timeout: float,
               procs: Sequence[subprocess.Popen]) -> bool:
    """Spin until done() or timeout; False as soon as a node process has exited."""
    end = time.monotonic() + timeout
    while not done():
        if time.monotonic() > end or any(p.poll() is not None for p in procs):
            return False
        executor.spin_once(timeout_sec=0.05)
    return True


# --- the demo ----------------------------------------------------------------------------
def rate_table(rates: dict[int, list[float]], uavs: Sequence[int],
               rate_min_bps: Sequence[float], tol_bps: float, per_line: int = 10) -> list[str]:
    """Each UAV's rates in Mbit/s, `per_line` slots a line; '!' marks a slot below R_min."""
    rows = []
    for k in uavs:
        rows.append(f"uav{k} (R_min {rate_min_bps[k] / 1e6:g} Mbit/s)")
        for first in range(0, len(rates[k]), per_line):
            cells = [f"{r / 1e6:6.2f}{'!' if r < rate_min_bps[k] - tol_bps else ' '}"
                     for r in rates[k][first:first + per_line]]
            last = first + len(cells) - 1
            rows.append(f"  {first:3d}-{last:<3d}" + "".join(cells))
    return rows


def run(args: argparse.Namespace) -> int:
    from uav_insar_planner.nodes.planner_report import rate_tolerance_bps
    from uav_insar_planner.params import ParamError, load_params, parse_override

    try:
        overrides = dict(parse_override(text) for text in args.param)
        if args.num_slots:
            overrides["num_slots"] = args.num_slots
        params = load_params(args.params_file, overrides)
    except ParamError as exc:
        print("\n".join(exc.problems), file=sys.stderr)
        return 2
    domain = args.domain_id if args.domain_id is not None else free_domain_id()
    os.environ.update(ros_env(domain))
    from uav_insar_planner.seam import Node, SingleThreadedExecutor, rclpy

    common = ["--params-file", str(args.params_file)] if args.params_file else []
    common += ["-p", f"num_slots:={params.num_slots}", *(a for text in args.param
                                                         for a in ("-p", text))]
    print(f"demo: ROS_DOMAIN_ID={domain}, {params.num_slots} slots of "
          f"{params.slot_duration_s:g} s at time_scale {args.time_scale:g}, scheme "
          f"{params.scheme}, solver {params.solver}", flush=True)
    rclpy.init(args=["demo"])
    node = Node("demo_watcher")
    watcher = Watcher(node)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    env = ros_env(domain)
    procs = [start_node("planner", common, env, "[planner]")]
    procs += [start_node("agent", [*common, "-p", f"uav_id:={k}", "-p",
                                   f"time_scale:={args.time_scale}", "-p",
                                   f"position_noise_std_m:={args.noise_std}",
                                   "-r", f"__node:=agent{k}"], env, f"[agent{k}]")
              for k in range(3)]
    code = 1
    try:
        if not spin_until(executor, lambda: (watcher.formation and watcher.power)
                          or watcher.plan_failed(), 40.0, procs) or watcher.plan_failed():
            print("demo: no plan on /formation (see the planner's log above)", flush=True)
            return 1
        with PRINT_LOCK:
            print("\n$ ros2 topic echo /formation  (first message)")
            print(message_yaml(watcher.formation) + "---", flush=True)
        uavs, n_slots = watcher.flown(), watcher.num_slots
        mission_s = n_slots * params.slot_duration_s + 60.0  # + transit and run-up
        complete = spin_until(executor, lambda: all(len(watcher.rates[k]) >= n_slots
                                                    for k in uavs),
                              mission_s / args.time_scale + 10.0, procs)
        tol = rate_tolerance_bps(params.rate_min_bps)
        with PRINT_LOCK:
            print("\nachieved rate per slot [Mbit/s], slots first-last ('!' = below R_min)")
            print("\n".join(rate_table(watcher.rates, uavs, params.rate_min_bps, tol)))
            print(summary(watcher, params, uavs, tol), flush=True)
        code = 0 if complete else 1
        if not complete:
            print("demo: the mission did not complete in time", flush=True)
        return code
    finally:
        codes = [stop_node(p) for p in procs]
        node.destroy_node()
        rclpy.try_shutdown()
        print(f"demo: stopped planner and agents (exit codes {codes})", flush=True)


def summary(watcher: Watcher, params: Params, uavs: Sequence[int], tol: float) -> str:
    """The plan and, per UAV, slots flown, rate met or missed and the worst margin."""
    lines = ["\nsummary"]
    if watcher.diagnostics is not None:
        for status in watcher.diagnostics.status:
            if status.name == PLAN_STATUS_NAME:
                lines.append(f"  plan: {status.message}")
    for k in uavs:
        p = watcher.formation.poses[k].position
        rates = watcher.rates[k]
        missed = sum(r < params.rate_min_bps[k] - tol for r in rates)
        worst = min(rates) - params.rate_min_bps[k] if rates else float("nan")
        verdict = "rate met in every slot" if rates and not missed else f"missed in {missed}"
        lines.append(f"  uav{k}: x={p.x:8.3f} m z={p.z:7.3f} m  {len(rates)}/{watcher.num_slots}"
                     f" slots, {verdict}, worst margin {worst:+.3g} bit/s")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Parse the options and fly the demo; returns the exit code (see the module docstring)."""
    parser = argparse.ArgumentParser(prog="python -m uav_insar_planner.demo",
                                     description="Fly one mission: planner + three agents.")
    parser.add_argument("--params-file", type=Path,
                        default=REPO_CONFIG if REPO_CONFIG.exists() else None,
                        help="ROS 2 params file for every node (default: config/params.yaml)")
    parser.add_argument("--num-slots", type=int, default=0,
                        help="override num_slots (default: the params file's)")
    parser.add_argument("--time-scale", type=float, default=20.0,
                        help="mission seconds per wall second (default 20)")
    parser.add_argument("--noise-std", type=float, default=0.0,
                        help="agents' position disturbance std per axis [m] (default 0)")
    parser.add_argument("-p", "--param", action="append", default=[], metavar="NAME:=VALUE",
                        help="a parameter for every node, e.g. -p solver:=paper-ao")
    parser.add_argument("--domain-id", type=int, default=None,
                        help="ROS_DOMAIN_ID to use (default: a random one in 1..101)")
    args = parser.parse_args(argv)
    if args.time_scale <= 0 or args.noise_std < 0:
        parser.error("--time-scale must be > 0 and --noise-std >= 0")
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
