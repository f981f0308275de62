"""Real-rclpy cost of the node suite: start-up to first /formation, RSS per node, latency.

Processes start as a user would start them (the console scripts next to sys.executable:
planner, agent, mavlink_bridge) on a private ROS_DOMAIN_ID (random in 1..232, or --domain)
with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST. The watcher is a node in this process on its own
rclpy Context. Measured:
1. start-up: wall ms from spawning `planner --ros-args -p num_slots:=80` (Table I defaults
   otherwise) to the watcher's first PoseArray on /formation (latched QoS, subscribed before the
   spawn); median/min/max over --runs. From the planner's log line "[stamp] ... solved in X s":
   its solve time, and the ms from that line to the receipt (publication to delivery, which
   includes the DDS discovery of the new process).
2. memory: VmRSS and VmHWM (/proc/PID/status, MiB) of a bare rclpy node, the planner, one agent
   (uav_id 0) and mavlink_bridge, all running together, read --settle s after the last one is
   in the graph (the planner counts as up once its plan arrived); this process for reference;
   each as a ratio to the bare node.
3. latency: a child node publishes a 3-pose PoseArray at 50 Hz on /bench/formation (latched
   QoS, header.stamp = its clock now); this process takes receive time - stamp (same host
   clock) for --messages messages after 10 warm-up ones: received, lost (depth 1 keep-last lets
   a sample be overwritten before this process takes it), p50/p99/max ms.
Not a test: prints tables. Children are stopped with SIGINT, SIGKILL after 5 s.

Run: .venv/bin/python benchmarks/ros_nodes.py [--runs 5] [--messages 500] [--settle 3]
"""
from __future__ import annotations

import argparse
import os
import random
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from contextlib import suppress
from pathlib import Path

import numpy as np
import rclpy
from geometry_msgs.msg import PoseArray
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

BIN = Path(sys.executable).parent
LATCHED = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                     reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
PLANNER = [str(BIN / "planner"), "--ros-args", "-p", "num_slots:=80"]
STOP_S, WARMUP = 5.0, 10
BARE = ("import rclpy\nrclpy.init()\nn = rclpy.create_node('bare_rclpy')\n"
        "try:\n    rclpy.spin(n)\nexcept BaseException:\n    pass\n")
PUBLISHER = """import sys, rclpy
from geometry_msgs.msg import Point, Pose, PoseArray
from rclpy.qos import DurabilityPolicy as D, HistoryPolicy as H, QoSProfile, ReliabilityPolicy as R
rclpy.init()
node = rclpy.create_node("bench_publisher")
qos = QoSProfile(depth=1, history=H.KEEP_LAST, reliability=R.RELIABLE, durability=D.TRANSIENT_LOCAL)
pub, total, seq = node.create_publisher(PoseArray, sys.argv[1], qos), int(sys.argv[2]), [0]
def tick():
    if seq[0] < total and pub.get_subscription_count() > 0:
        msg = PoseArray(poses=[Pose(position=Point(x=float(k))) for k in range(3)])
        msg.header.frame_id = str(seq[0])
        msg.header.stamp = node.get_clock().now().to_msg()
        pub.publish(msg)
        seq[0] += 1
node.create_timer(0.02, tick)
try:
    rclpy.spin(node)
except BaseException:
    pass
"""


class Watcher:
    """One node on a private Context; `spin_until` runs its executor until a predicate holds."""

    def __init__(self) -> None:
        self.context = rclpy.Context()
        rclpy.init(args=["ros_nodes"], context=self.context)
        self.node = rclpy.create_node("bench_watcher", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)

    def spin_until(self, done: Callable[[], bool], timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while not done():
            if time.monotonic() > deadline:
                return False
            self.executor.spin_once(timeout_sec=0.02)
        return True

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def spawn(cmd: list[str], log: Path, env: dict[str, str]) -> subprocess.Popen:
    """Start `cmd` in its own session, stdout + stderr to `log`."""
    with open(log, "w") as out:
        return subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=out,
                                stderr=subprocess.STDOUT, env=env, start_new_session=True)


def stop(proc: subprocess.Popen) -> None:
    """SIGINT to the child's process group, SIGKILL if it is still there after STOP_S."""
    for sig in (signal.SIGINT, signal.SIGKILL):
        if proc.poll() is not None:
            return
        with suppress(ProcessLookupError):
            os.killpg(proc.pid, sig)
        with suppress(subprocess.TimeoutExpired):
            proc.wait(STOP_S)


def failed(what: str, proc: subprocess.Popen, log: Path) -> RuntimeError:
    tail = "\n".join(log.read_text(errors="replace").splitlines()[-15:])
    return RuntimeError(f"{what} (exit code {proc.poll()}); last lines of {log}:\n{tail}")


def mem_mib(pid: int) -> tuple[float, float]:
    """(VmRSS, VmHWM) of `pid` in MiB."""
    fields = dict(line.split(":", 1) for line in Path(f"/proc/{pid}/status").read_text()
                  .splitlines() if ":" in line)
    return tuple(int(fields[k].split()[0]) / 1024 for k in ("VmRSS", "VmHWM"))


def startup(w: Watcher, log: Path, env: dict[str, str],
            timeout: float) -> tuple[float, float, float]:
    """(ms from spawn to the first /formation, solve ms, ms from the planner's "solved" log line
    to the receipt; the last two nan when that line is missing) of one planner."""
    got: list[tuple[float, float]] = []
    sub = w.node.create_subscription(
        PoseArray, "/formation", lambda _: got.append((time.perf_counter(), time.time())), LATCHED)
    start = time.perf_counter()
    proc = spawn(PLANNER, log, env)
    try:
        w.spin_until(lambda: bool(got) or proc.poll() is not None, timeout)
    finally:
        stop(proc)
        w.node.destroy_subscription(sub)
    if not got:
        raise failed(f"no /formation within {timeout:.0f} s", proc, log)
    solved = re.search(r"\[(\d+\.\d+)\] \[planner\]: .*solved in ([0-9.eE+-]+) s",
                       log.read_text(errors="replace"))
    ms = (got[0][0] - start) * 1e3
    if solved is None:
        return ms, float("nan"), float("nan")
    return ms, float(solved[2]) * 1e3, (got[0][1] - float(solved[1])) * 1e3


def memory(w: Watcher, logdir: Path, env: dict[str, str], settle: float,
           timeout: float) -> list[tuple[str, float, float]]:
    """(label, RSS MiB, peak RSS MiB) of each node, all running together, and of this process."""
    got: list[bool] = []
    sub = w.node.create_subscription(PoseArray, "/formation", lambda _: got.append(True), LATCHED)
    nodes = [("bare rclpy node", [sys.executable, "-c", BARE], "bare_rclpy"),
             ("planner", PLANNER, "planner"),
             ("agent uav_id:=0", [str(BIN / "agent"), "--ros-args", "-p", "uav_id:=0"], "agent"),
             ("mavlink_bridge", [str(BIN / "mavlink_bridge")], "mavlink_bridge")]
    procs: list[tuple[str, subprocess.Popen]] = []
    try:
        for label, cmd, name in nodes:
            log = logdir / f"mem_{name}.log"
            proc = spawn(cmd, log, env)
            procs.append((label, proc))

            def up(name: str = name) -> bool:
                return name in w.node.get_node_names() and (name != "planner" or bool(got))
            w.spin_until(lambda proc=proc: up() or proc.poll() is not None, timeout)
            if proc.poll() is not None or not up():
                raise failed(f"{label} not up within {timeout:.0f} s", proc, log)
        w.spin_until(lambda: False, settle)
        rows = [(label, *mem_mib(proc.pid)) for label, proc in procs]
        return rows + [("this watcher process", *mem_mib(os.getpid()))]
    finally:
        for _, proc in procs:
            stop(proc)
        w.node.destroy_subscription(sub)


def latency(w: Watcher, log: Path, env: dict[str, str], n: int) -> tuple[list[float], int]:
    """(receive time - header.stamp in ms, number lost) of `n` PoseArrays from a 50 Hz child
    publisher after WARMUP ones; header.frame_id carries the sequence number."""
    lat: dict[int, float] = {}
    total = n + WARMUP

    def on_msg(msg: PoseArray) -> None:
        now = time.time_ns()
        lat[int(msg.header.frame_id)] = (now - msg.header.stamp.sec * 10**9
                                         - msg.header.stamp.nanosec) / 1e6
    sub = w.node.create_subscription(PoseArray, "/bench/formation", on_msg, LATCHED)
    proc = spawn([sys.executable, "-c", PUBLISHER, "/bench/formation", str(total)], log, env)
    try:  # depth 1 keeps the last sample, so the last one always arrives
        w.spin_until(lambda: total - 1 in lat or proc.poll() is not None,
                     30.0 + 2 * 0.02 * total)
    finally:
        stop(proc)
        w.node.destroy_subscription(sub)
    if total - 1 not in lat:
        raise failed(f"last message never arrived ({len(lat)} of {total} did)", proc, log)
    got = [ms for seq, ms in sorted(lat.items()) if seq >= WARMUP]
    return got, n - len(got)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--messages", type=int, default=500)
    ap.add_argument("--settle", type=float, default=3.0, help="s between up and the RSS reading")
    ap.add_argument("--timeout", type=float, default=120.0, help="s to wait for a node / plan")
    ap.add_argument("--domain", type=int, default=random.randint(1, 232))
    args = ap.parse_args()
    os.environ.update(ROS_DOMAIN_ID=str(args.domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    logdir = Path(tempfile.mkdtemp(prefix="ros_nodes_bench_"))
    env = dict(os.environ, PYTHONUNBUFFERED="1", ROS_LOG_DIR=str(logdir / "ros"))
    print(f"ROS_DOMAIN_ID={args.domain}, discovery LOCALHOST, "
          f"RMW {os.environ.get('RMW_IMPLEMENTATION', 'default')}; child logs in {logdir}")
    w = Watcher()
    try:
        runs = [startup(w, logdir / f"planner_{i}.log", env, args.timeout)
                for i in range(args.runs)]
        print(f"\n1. planner (num_slots 80) spawn -> first /formation, {args.runs} runs")
        print(f"{'':14} {'median ms':>10} {'min ms':>8} {'max ms':>8}   each run ms")
        for label, col in zip(("start-up", "solve", "log -> receipt"), zip(*runs, strict=True),
                              strict=True):
            vals = [v for v in col if v == v] or [float("nan")]  # nan: no "solved" log line
            print(f"{label:14} {statistics.median(vals):10.1f} {min(vals):8.1f} "
                  f"{max(vals):8.1f}   " + " ".join(f"{v:.1f}" for v in vals))
        rows = memory(w, logdir, env, args.settle, args.timeout)
        print(f"\n2. resident memory, all nodes running, {args.settle:g} s after the last is up")
        print(f"{'process':22} {'RSS MiB':>8} {'peak MiB':>9} {'RSS / bare':>10}")
        for label, rss, hwm in rows:
            print(f"{label:22} {rss:8.1f} {hwm:9.1f} {rss / rows[0][1]:10.2f}")
        got, lost = latency(w, logdir / "publisher.log", env, args.messages)
        lat = np.array(got)
        print(f"\n3. PoseArray (3 poses, latched QoS) child -> here, 50 Hz, {args.messages} sent")
        print(f"{'received':>8} {'lost':>5} {'p50 ms':>8} {'p99 ms':>8} {'max ms':>8}")
        print(f"{len(lat):8d} {lost:5d} {np.percentile(lat, 50):8.3f} "
              f"{np.percentile(lat, 99):8.3f} {lat.max():8.3f}")
    finally:
        w.close()


if __name__ == "__main__":
    main()
