"""What `uav-insar record` keeps up with: messages/s recorded against a bare rclpy counter.

On a private ROS_DOMAIN_ID (random, discovery on this host), for each target rate this process
publishes geometry_msgs/PoseStamped (the suite's most frequent type) on /bench/pose, reliable,
keep-last 1000, paced to the rate for --seconds; two processes subscribe: the recorder
(`python -m uav_insar_planner.cli record OUT --topics /bench/pose`, raw bytes into an MCAP
bag) and, side by side, a bare rclpy node that only counts raw messages (the floor of what a
Python subscriber costs). Both are stopped with SIGINT 2 s after the last message; the
recorded count comes from the bag's metadata.yaml, the recorder's CPU seconds from /proc
(utime+stime). Printed per rate: published, the rate reached, recorded and counted (% of
published), the ratio of the two, and the recorder's CPU time per
message recorded (from the first message to the stop).

Run: .venv/bin/python benchmarks/recorder.py [--rates 500 2000 5000 20000] [--seconds 3]
"""
from __future__ import annotations

import argparse
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
TOPIC = "/bench/pose"
COUNTER = """
import rclpy
from geometry_msgs.msg import PoseStamped
from rclpy.executors import ExternalShutdownException
from rclpy.qos import QoSProfile
rclpy.init()
node = rclpy.create_node("bench_counter")
count = 0
def seen(data):
    global count
    count += 1
node.create_subscription(PoseStamped, "TOPIC", seen, QoSProfile(depth=1000), raw=True)
try:
    rclpy.spin(node)
except (KeyboardInterrupt, ExternalShutdownException):
    pass
print(count, flush=True)
""".replace("TOPIC", TOPIC)


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run_rate(rate: float, seconds: float, env: dict[str, str], folder: Path) -> dict:
    import rclpy
    from geometry_msgs.msg import PoseStamped
    from rclpy.qos import QoSProfile

    bag = folder / f"bench_{int(rate)}"
    recorder = subprocess.Popen([sys.executable, "-m", "uav_insar_planner.cli", "record",
                                 str(bag), "--topics", TOPIC], env=env, text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    counter = subprocess.Popen([sys.executable, "-c", COUNTER], env=env, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=int(env["ROS_DOMAIN_ID"]))
    node = rclpy.create_node("bench_publisher", context=ctx)
    pub = node.create_publisher(PoseStamped, TOPIC, QoSProfile(depth=1000))
    end = time.monotonic() + 30.0
    while pub.get_subscription_count() < 2 and time.monotonic() < end:
        time.sleep(0.05)
    time.sleep(1.0)  # the recorder subscribes on its next graph look; let both settle
    cpu_before = cpu_s(recorder.pid)
    msg = PoseStamped()
    msg.header.frame_id = "insar_track"
    sent, start = 0, time.monotonic()
    while (now := time.monotonic()) - start < seconds:
        due = int((now - start) * rate) + 1
        while sent < due:
            msg.pose.position.y = float(sent)
            pub.publish(msg)
            sent += 1
        time.sleep(0.0005)
    elapsed = time.monotonic() - start
    time.sleep(2.0)
    used = cpu_s(recorder.pid) - cpu_before
    for proc in (recorder, counter):
        proc.send_signal(signal.SIGINT)
    counted = int(counter.communicate(timeout=20)[0].split()[-1])
    recorder.communicate(timeout=20)
    node.destroy_node()
    ctx.try_shutdown()
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    return {"rate": rate, "sent": sent, "reached": sent / elapsed,
            "recorded": info["message_count"], "counted": counted, "cpu_s": used}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rates", type=float, nargs="+", default=[500, 2000, 5000, 20000])
    parser.add_argument("--seconds", type=float, default=3.0)
    args = parser.parse_args()
    from uav_insar_planner.demo.processes import ros_env

    env = dict(ros_env(random.randint(110, 230)), PYTHONPATH=str(REPO))
    print(f"ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}, {args.seconds:g} s per rate, PoseStamped "
          f"on {TOPIC}")
    print(f"{'target/s':>9} {'sent':>7} {'reached/s':>10} {'recorded':>9} {'%':>6} "
          f"{'bare count':>10} {'%':>6} {'rec/bare':>8} {'recorder CPU us/msg':>20}")
    with tempfile.TemporaryDirectory() as folder:
        for rate in args.rates:
            r = run_rate(rate, args.seconds, env, Path(folder))
            print(f"{r['rate']:9.0f} {r['sent']:7d} {r['reached']:10.0f} {r['recorded']:9d} "
                  f"{100 * r['recorded'] / r['sent']:6.1f} {r['counted']:10d} "
                  f"{100 * r['counted'] / r['sent']:6.1f} "
                  f"{r['recorded'] / max(r['counted'], 1):8.2f} "
                  f"{1e6 * r['cpu_s'] / max(r['recorded'], 1):20.0f}",
                  flush=True)


if __name__ == "__main__":
    main()
