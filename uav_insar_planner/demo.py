"""`make demo` / `python -m uav_insar_planner.demo`: one whole mission, eight processes.

Starts three `agent` executables and the `planner` as separate processes, as `ros2 run` would,
on a private ROS_DOMAIN_ID with discovery kept on this host; this process watches the topics
like `ros2 topic echo` would. Unless `--no-mavlink`, it also closes the MAVLink loop: three
`uav-insar-vehicle` processes (SITL-style, sysid 2..4, airborne, on free loopback UDP ports)
and the `mavlink_bridge` node wired to them, which flies the planned formation through real
MAVLink bytes; the vehicles' positions come back on /uavK/mavlink/pose. The vehicles fly in
wall-clock time (no time_scale): they gather at their start points, then fly a short pass of
`--mavlink-pass-s` seconds along the track at speed_mps.

It prints /formation, each UAV's achieved rate per slot (a compact table), the MAVLink
vehicles (a table), and a summary (per UAV: slots and rates; per vehicle: the across-track
error to the planned (x_k, z_k) on the pass, max and final, and the distance flown along the
track); then stops every process with SIGINT (as Ctrl-C would).

Exit code 0 when every flown UAV reported every slot and every flown vehicle flew its pass;
1 when something did not happen in time (no plan, a process died, slots missing, no pass);
2 for bad options.
"""
from __future__ import annotations

import argparse
import math
import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from uav_insar_planner.params import Params
from uav_insar_planner.ros.diagnostics import ERROR, PLAN_STATUS_NAME

REPO_CONFIG = Path(__file__).resolve().parents[1] / "config" / "params.yaml"
STOP_TIMEOUT_S = 5.0
# MAVLink part: the bridge starts the pass once every vehicle is this close to its start point
# (tighter than the bridge's 1 m default, so the pass shows tracking, not the approach).
CAPTURE_RADIUS_M = 0.2
SETTLE_S = 3.0  # after the pass: the vehicles brake past its end and return; then the final error
MAVLINK_TIMEOUT_S = 30.0  # for the approach and the pass, after the agents are done
FIRST_SYSID = 2  # vehicles sysid 2, 3, 4: the bridge's default target_sysids
MODULES = {"planner": "uav_insar_planner.ros.planner", "agent": "uav_insar_sim.agent_node",
           "mavlink_bridge": "uav_insar_planner.ros.mavlink_bridge",
           "uav-insar-vehicle": "uav_insar_sim.vehicle"}
# Held while the demo prints a block (echo, table), so node log lines do not cut into it.
PRINT_LOCK = threading.Lock()


# --- processes ---------------------------------------------------------------------------
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
        def pump() -> None:
            for line in proc.stdout:
                with PRINT_LOCK:
                    print(f"{echo_prefix} {line.rstrip()}", flush=True)

        threading.Thread(target=pump, daemon=True).start()
    return proc


def stop_node(proc: subprocess.Popen, timeout: float = STOP_TIMEOUT_S) -> int:
    """SIGINT (Ctrl-C), then SIGTERM, then SIGKILL, each given `timeout`; returns the exit code."""
    return stop_nodes([proc], timeout)[0]


def stop_nodes(procs: Sequence[subprocess.Popen], timeout: float = STOP_TIMEOUT_S) -> list[int]:
    """`stop_node` for all of `procs` at once (each signal to all, then one shared wait), so
    they shut down in parallel; returns their exit codes in order."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
        alive = [p for p in procs if p.poll() is None]
        for proc in alive:
            proc.send_signal(sig)
        end = time.monotonic() + timeout
        for proc in alive:
            try:
                proc.wait(max(0.0, end - time.monotonic()))
            except subprocess.TimeoutExpired:
                continue
    return [p.wait() for p in procs]


def free_domain_id() -> int:
    """A random domain id in 1..101 (its discovery ports stay below the ephemeral range)."""
    return random.randint(1, 101)


def free_udp_ports(count: int) -> list[int]:
    """`count` distinct UDP ports on 127.0.0.1 that are free now (bound together, released)."""
    socks = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(count)]
    try:
        for sock in socks:
            sock.bind(("127.0.0.1", 0))
        return [sock.getsockname()[1] for sock in socks]
    finally:
        for sock in socks:
            sock.close()


def start_mavlink(ports: Sequence[int], pass_s: float, common: Sequence[str],
                  env: dict[str, str]) -> list[subprocess.Popen]:
    """Three vehicles (sysid 2..4, airborne 20 m up, listening on 127.0.0.1:ports[k]) and the
    bridge sending to them; the vehicles first, so the bridge's first datagrams find them."""
    procs = [start_process([*executable("uav-insar-vehicle"), "--sysid",
                            str(FIRST_SYSID + k), "--listen", f"udpin:127.0.0.1:{port}",
                            "--airborne", "--start-ned", "0", str(3 * k), "-20"],
                           env, f"[vehicle{FIRST_SYSID + k}]")
             for k, port in enumerate(ports)]
    connections = ", ".join(f"'udpout:127.0.0.1:{port}'" for port in ports)
    sysids = ", ".join(str(FIRST_SYSID + k) for k in range(len(ports)))
    procs.append(start_node("mavlink_bridge", [
        *common, "-p", f"connections:=[{connections}]", "-p", f"target_sysids:=[{sysids}]",
        "-p", "velocity_feedforward:=true", "-p", f"capture_radius_m:={CAPTURE_RADIUS_M}",
        "-p", f"track_duration_s:={float(pass_s)}"], env, "[bridge]"))
    return procs


# --- watching ----------------------------------------------------------------------------
Vec3 = tuple[float, float, float]


@dataclass
class PassRecord:
    """One vehicle on the MAVLink pass (metres): across-track error to its planned (x_k, z_k),
    worst and latest, and its distance along the track from y_start."""

    max_error: float = 0.0
    final_error: float = math.nan
    along_track: float = 0.0


class MavlinkPass:
    """Follows the vehicles' positions (/uavK/mavlink/pose) against their start points
    `starts[k]` = (x_k, y_start, z_k). The pass begins (`began`, monotonic time) when every
    vehicle is within `capture_radius` of its start point, the bridge's own rule; from then
    on every position updates that vehicle's PassRecord."""

    def __init__(self, starts: dict[int, Vec3], capture_radius: float) -> None:
        self.starts = starts
        self.capture_radius = capture_radius
        self.latest: dict[int, Vec3] = {}
        self.poses = dict.fromkeys(starts, 0)
        self.records = {k: PassRecord() for k in starts}
        self.began: float | None = None

    def update(self, k: int, position: Vec3, now: float) -> None:
        if k not in self.starts:
            return
        self.latest[k] = position
        self.poses[k] += 1
        if self.began is None:
            if len(self.latest) == len(self.starts) and all(
                    math.dist(self.latest[j], start) <= self.capture_radius
                    for j, start in self.starts.items()):
                self.began = now
            return
        x, y, z = position
        x_k, y_start, z_k = self.starts[k]
        record = self.records[k]
        record.final_error = math.hypot(x - x_k, z - z_k)
        record.max_error = max(record.max_error, record.final_error)
        record.along_track = y - y_start

    def done(self, now: float, duration: float) -> bool:
        """True once the pass began at least `duration` seconds ago."""
        return self.began is not None and now - self.began >= duration


class Watcher:
    """A node that records /formation, /formation/power, rates, the planner's plan status
    and, once `mavlink_pass` is set, the vehicles' positions."""

    def __init__(self, node: Any) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import PoseArray, PoseStamped
        from std_msgs.msg import Float64, Float64MultiArray

        from uav_insar_planner.ros.topics import LATCHED

        self.node = node
        self.formation = None
        self.power = None
        self.rates: dict[int, list[float]] = {0: [], 1: [], 2: []}
        self.plan_status = None
        self.mavlink_pass: MavlinkPass | None = None
        node.create_subscription(PoseArray, "formation",
                                 self._on_formation, LATCHED)
        node.create_subscription(Float64MultiArray, "formation/power",
                                 self._on_power, LATCHED)
        node.create_subscription(DiagnosticArray, "/diagnostics",
                                 self._on_diagnostics, 10)
        for k in range(3):
            node.create_subscription(Float64, f"uav{k}/achieved_rate",
                                     lambda msg, k=k: self.rates[k].append(msg.data), 100)
            node.create_subscription(PoseStamped,
                                     f"uav{k}/mavlink/pose",
                                     lambda msg, k=k: self._on_mavlink_pose(k, msg), 100)

    def _on_formation(self, msg) -> None:
        self.formation = msg

    def _on_power(self, msg) -> None:
        self.power = msg

    def _on_diagnostics(self, msg) -> None:
        # The bridge publishes on /diagnostics too: keep the planner's plan status only.
        for status in msg.status:
            if status.name == PLAN_STATUS_NAME:
                self.plan_status = status

    def _on_mavlink_pose(self, k: int, msg) -> None:
        if self.mavlink_pass is not None:
            p = msg.pose.position
            self.mavlink_pass.update(k, (p.x, p.y, p.z), time.monotonic())

    def agents_matched(self) -> bool:
        """True once this node has discovered every agent's achieved_rate publisher."""
        return all(self.node.count_publishers(f"/uav{k}/achieved_rate") for k in range(3))

    def plan_failed(self) -> bool:
        """True once /diagnostics reports the plan as ERROR (infeasible or solve failed)."""
        s = self.plan_status
        return s is not None and bool(s.message) and level_of(s) == ERROR

    @property
    def num_slots(self) -> int:
        return self.power.layout.dim[1].size if self.power is not None else 0

    def flown(self) -> list[int]:
        """UAVs the plan flies (finite target)."""
        return [k for k, p in enumerate(self.formation.poses) if math.isfinite(p.position.x)]


def level_of(status: Any) -> int:
    """DiagnosticStatus.level as an int (rclpy gives the byte field as a 1-byte bytes)."""
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


def mavlink_table(mavlink_pass: MavlinkPass, ports: Sequence[int]) -> list[str]:
    """One line per vehicle: sysid, endpoint, positions received, planned (x_k, z_k) and the
    last position, all in the track frame."""
    rows = ["  uav   sysid  vehicle endpoint         poses   target x, z      last x, y, z"]
    for k, (x_k, _, z_k) in mavlink_pass.starts.items():
        last = mavlink_pass.latest.get(k)
        where = "-" if last is None else " ".join(f"{c:8.3f}" for c in last)
        rows.append(f"  uav{k}  {FIRST_SYSID + k:5d}  udpin:127.0.0.1:{ports[k]:<6d}  "
                    f"{mavlink_pass.poses[k]:5d}  {x_k:8.3f} {z_k:7.3f}  {where}")
    return rows


def run(args: argparse.Namespace) -> int:
    from uav_insar_planner.evaluate import rate_tolerance_bps
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
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    from uav_insar_planner.ros.msg_yaml import message_to_yaml

    common = ["--params-file", str(args.params_file)] if args.params_file else []
    common += ["-p", f"num_slots:={params.num_slots}", *(a for text in args.param
                                                         for a in ("-p", text))]
    print(f"demo: ROS_DOMAIN_ID={domain}, {params.num_slots} slots of "
          f"{params.slot_duration_s:g} s at time_scale {args.time_scale:g}, scheme "
          f"{params.scheme}, solver {params.solver}", flush=True)
    context = rclpy.Context()
    rclpy.init(args=["demo"], context=context)
    node = Node("demo_watcher", context=context)
    watcher = Watcher(node)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    env = ros_env(domain)
    procs = [start_node("agent", [*common, "-p", f"uav_id:={k}", "-p",
                                  f"time_scale:={args.time_scale}", "-p",
                                  f"position_noise_std_m:={args.noise_std}",
                                  "-r", f"__node:=agent{k}"], env, f"[agent{k}]")
             for k in range(3)]
    ports: list[int] = []
    code = 1
    try:
        # A new process can take a discovery announcement period (~3 s) to be seen: the
        # watcher must see the agents before the plan starts their slots, or it misses rates.
        if not spin_until(executor, watcher.agents_matched, 20.0, procs):
            print("demo: the agents did not come up (see their log above)", flush=True)
            return 1
        procs.append(start_node("planner", common, env, "[planner]"))
        if not args.no_mavlink:
            ports = ([args.mavlink_base_port + 10 * k for k in range(3)]
                     if args.mavlink_base_port else free_udp_ports(3))
            print(f"demo: MAVLink vehicles sysid {FIRST_SYSID}..{FIRST_SYSID + 2} on UDP "
                  f"ports {', '.join(map(str, ports))}, pass of {args.mavlink_pass_s:g} s",
                  flush=True)
            procs += start_mavlink(ports, args.mavlink_pass_s, common, env)
        if not spin_until(executor, lambda: (watcher.formation and watcher.power)
                          or watcher.plan_failed(), 40.0, procs) or watcher.plan_failed():
            print("demo: no plan on /formation (see the planner's log above)", flush=True)
            return 1
        plan_time = time.monotonic()
        with PRINT_LOCK:
            print("\n$ ros2 topic echo /formation  (first message)")
            print(message_to_yaml(watcher.formation) + "---", flush=True)
        uavs, n_slots = watcher.flown(), watcher.num_slots
        if not args.no_mavlink:
            starts = {k: (p.x, p.y, p.z) for k, p in
                      ((k, watcher.formation.poses[k].position) for k in uavs)}
            watcher.mavlink_pass = MavlinkPass(starts, CAPTURE_RADIUS_M)
        mission_s = n_slots * params.slot_duration_s + 60.0  # + transit and run-up
        complete = spin_until(executor, lambda: all(len(watcher.rates[k]) >= n_slots
                                                    for k in uavs),
                              mission_s / args.time_scale + 10.0, procs)
        flew_pass = args.no_mavlink or spin_until(
            executor, lambda: watcher.mavlink_pass.done(time.monotonic(),
                                                        args.mavlink_pass_s + SETTLE_S),
            MAVLINK_TIMEOUT_S, procs)
        tol = rate_tolerance_bps(params.rate_min_bps)
        with PRINT_LOCK:
            print("\nachieved rate per slot [Mbit/s], slots first-last ('!' = below R_min)")
            print("\n".join(rate_table(watcher.rates, uavs, params.rate_min_bps, tol)))
            if watcher.mavlink_pass is not None:
                print("\nMAVLink vehicles (track frame [m]; positions from /uavK/mavlink/pose)")
                print("\n".join(mavlink_table(watcher.mavlink_pass, ports)))
            print(summary(watcher, params, uavs, tol, plan_time,
                          args.mavlink_pass_s * params.speed), flush=True)
        if not complete:
            print("demo: the mission did not complete in time", flush=True)
        if not flew_pass:
            print("demo: the MAVLink vehicles did not fly their pass in time", flush=True)
        code = 0 if complete and flew_pass else 1
        return code
    finally:
        codes = stop_nodes(procs)
        node.destroy_node()
        context.try_shutdown()
        what = "planner and agents" if args.no_mavlink else "planner, agents, vehicles, bridge"
        print(f"demo: stopped {what} (exit codes {codes})", flush=True)


def summary(watcher: Watcher, params: Params, uavs: Sequence[int], tol: float,
            plan_time: float, pass_m: float) -> str:
    """The plan and, per UAV, slots flown, rate met or missed and the worst margin; per
    MAVLink vehicle, its across-track error on the pass and its distance along the track
    (the pass is `pass_m` long)."""
    lines = ["\nsummary"]
    if watcher.plan_status is not None:
        lines.append(f"  plan: {watcher.plan_status.message}")
    for k in uavs:
        p = watcher.formation.poses[k].position
        rates = watcher.rates[k]
        missed = sum(r < params.rate_min_bps[k] - tol for r in rates)
        worst = min(rates) - params.rate_min_bps[k] if rates else float("nan")
        verdict = "rate met in every slot" if rates and not missed else f"missed in {missed}"
        lines.append(f"  uav{k}: x={p.x:8.3f} m z={p.z:7.3f} m  {len(rates)}/{watcher.num_slots}"
                     f" slots, {verdict}, worst margin {worst:+.3g} bit/s")
    mp = watcher.mavlink_pass
    if mp is not None and mp.began is None:
        lines.append("  MAVLink: the vehicles never gathered at their start points")
    elif mp is not None:
        lines.append(f"  MAVLink: formation established {mp.began - plan_time:.1f} s after the "
                     f"plan (all within {mp.capture_radius:g} m), then the pass")
        for k, r in mp.records.items():
            lines.append(f"  uav{k} via MAVLink: across-track error max {r.max_error:.3f} m, "
                         f"final {r.final_error:.3f} m; flew {r.along_track:.1f} m along track "
                         f"(pass {pass_m:.1f} m)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Parse the options and fly the demo; returns the exit code (see the module docstring)."""
    parser = argparse.ArgumentParser(prog="python -m uav_insar_planner.demo",
                                     description="Fly one mission: planner + three agents, "
                                                 "and the MAVLink bridge + three vehicles.")
    parser.add_argument("--params-file", type=Path,
                        default=REPO_CONFIG if REPO_CONFIG.exists() else None,
                        help="ROS 2 params file for every node (default: config/params.yaml)")
    parser.add_argument("--num-slots", type=int, default=0,
                        help="override num_slots (default: the params file's)")
    parser.add_argument("--time-scale", type=float, default=20.0,
                        help="agents' mission seconds per wall second (default 20)")
    parser.add_argument("--noise-std", type=float, default=0.0,
                        help="agents' position disturbance std per axis [m] (default 0)")
    parser.add_argument("-p", "--param", action="append", default=[], metavar="NAME:=VALUE",
                        help="a parameter for every node, e.g. -p solver:=paper-ao")
    parser.add_argument("--domain-id", type=int, default=None,
                        help="ROS_DOMAIN_ID to use (default: a random one in 1..101)")
    parser.add_argument("--no-mavlink", action="store_true",
                        help="skip the MAVLink part (bridge and vehicles)")
    parser.add_argument("--mavlink-pass-s", type=float, default=5.0,
                        help="how long the vehicles fly along the track, wall clock (default 5)")
    parser.add_argument("--mavlink-base-port", type=int, default=0,
                        help="vehicles listen on UDP PORT, PORT+10, PORT+20 (default: free "
                             "ports chosen by the OS)")
    args = parser.parse_args(argv)
    if args.time_scale <= 0 or args.noise_std < 0:
        parser.error("--time-scale must be > 0 and --noise-std >= 0")
    if not args.mavlink_pass_s > 0 or not 0 <= args.mavlink_base_port <= 65515:
        parser.error("--mavlink-pass-s must be > 0 and --mavlink-base-port in 0..65515")
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
