"""/formation delivery latency between two processes, and their resident memory.

    .venv/bin/python benchmarks/pubsub_latency.py [--count 200] [--period 0.01]

The publisher (this process) sends PoseArray messages with 3 poses on /formation (reliable,
transient_local, depth 1) stamped with the send time; a subscriber process (the same script
with --subscriber) computes receive time minus stamp for each and reports median and p99,
plus its VmRSS. Then the real `planner` node is started as a process and its VmRSS / VmHWM
are read once its first /formation has arrived. All run on the seam (rclpy when installed,
else our runtime), in a private ROS domain unless ROS_DOMAIN_ID is set.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from uav_insar_planner.seam import (  # noqa: E402 - after the path fix for direct runs
    USING_RCLPY,
    DurabilityPolicy,
    Node,
    QoSProfile,
    msg_type,
    rclpy,
)

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
PoseArray = msg_type("geometry_msgs/msg/PoseArray")
Pose = msg_type("geometry_msgs/msg/Pose")


def vm_rss_kib(pid: int | str = "self", field: str = "VmRSS") -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    return -1


def planner_memory(node: Node, env: dict[str, str]) -> tuple[int, int]:
    """(VmRSS, VmHWM) in KiB of a `planner` process once it has published its first plan."""
    got: list[object] = []
    node.create_subscription(PoseArray, "/formation", lambda m: got.append(m)
                             if m.header.frame_id == "insar_track" else None, LATCHED)
    proc = subprocess.Popen([sys.executable, "-m", "uav_insar_planner.nodes.planner"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        end = time.monotonic() + 60
        while not got and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.2)
        if not got:
            raise SystemExit("the planner published no /formation within 60 s")
        time.sleep(0.5)
        return vm_rss_kib(proc.pid), vm_rss_kib(proc.pid, "VmHWM")
    finally:
        proc.terminate()
        proc.wait(timeout=20)


def subscriber(count: int) -> None:
    rclpy.init(args=[])
    node = Node("latency_sub")
    latencies: list[int] = []

    def on_msg(msg: object) -> None:
        now = time.time_ns()
        sent = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if msg.header.frame_id == "bench":
            latencies.append(now - sent)

    node.create_subscription(PoseArray, "/formation", on_msg, LATCHED)
    print("ready", flush=True)
    end = time.monotonic() + 60
    while len(latencies) < count and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.5)
    print(json.dumps({"latencies_ns": latencies, "rss_kib": vm_rss_kib()}), flush=True)
    rclpy.shutdown()


def publisher(count: int, period: float) -> None:
    env = dict(os.environ)
    env.setdefault("ROS_DOMAIN_ID", str(1 + os.getpid() % 101))
    os.environ.update(env)
    sub = subprocess.Popen([sys.executable, __file__, "--subscriber", "--count", str(count)],
                           env=env, stdout=subprocess.PIPE, text=True)
    try:
        assert sub.stdout.readline().strip() == "ready"
        rclpy.init(args=[])
        node = Node("latency_pub")
        pub = node.create_publisher(PoseArray, "/formation", LATCHED)
        end = time.monotonic() + 20
        while pub.get_subscription_count() < 1 and time.monotonic() < end:
            time.sleep(0.01)
        time.sleep(0.2)
        msg = PoseArray(poses=[Pose(), Pose(), Pose()])
        msg.header.frame_id = "bench"
        for k in range(count):
            for i, pose in enumerate(msg.poses):
                pose.position.x, pose.position.y = 10.0 * i, 0.1 * k
            now = time.time_ns()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 1_000_000_000)
            pub.publish(msg)
            time.sleep(period)
        pub_rss = vm_rss_kib()
        out, _ = sub.communicate(timeout=60)
        result = json.loads(out.strip().splitlines()[-1])
        lat = sorted(result["latencies_ns"])
        if not lat:
            raise SystemExit("no messages received")
        p99 = lat[min(len(lat) - 1, int(round(0.99 * (len(lat) - 1))))]
        print(f"runtime: {'rclpy' if USING_RCLPY else 'embedded (Cyclone DDS)'}")
        print(f"/formation PoseArray(3 poses), reliable transient_local depth 1, "
              f"{len(lat)}/{count} received, one every {period * 1e3:g} ms")
        print(f"latency median: {statistics.median(lat) / 1e3:.0f} us   "
              f"p99: {p99 / 1e3:.0f} us   max: {lat[-1] / 1e3:.0f} us")
        print(f"resident memory (VmRSS): publisher {pub_rss / 1024:.1f} MiB, "
              f"subscriber {result['rss_kib'] / 1024:.1f} MiB")
        rss, hwm = planner_memory(node, env)
        print(f"planner process (solver=global): VmRSS {rss / 1024:.1f} MiB, "
              f"peak VmHWM {hwm / 1024:.1f} MiB")
        rclpy.shutdown()
    finally:
        if sub.poll() is None:
            sub.kill()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=200)
    parser.add_argument("--period", type=float, default=0.01)
    parser.add_argument("--subscriber", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.subscriber:
        subscriber(args.count)
    else:
        publisher(args.count, args.period)


if __name__ == "__main__":
    main()
