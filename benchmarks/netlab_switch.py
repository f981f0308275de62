"""What the netlab switch (uav_insar_sim/netlab/switch.py) forwards: frames/s and its CPU.

Part 1, UDP flood: a NetLab of two namespaces; a sender in "uav0" paces UDP datagrams of
--size bytes to a counter in "ground" at each target rate for --seconds (one Python sender;
"max" sends as fast as it can). Printed per rate: datagrams sent, received (% of sent) and
the switch's CPU (utime+stime from /proc, % of one core over the sending time). Loss here is
the switch (or the receiver) falling behind: the switch impairs nothing in this run.

Part 2, DDS load: --dds-nodes processes in "uav0" each publish std_msgs/String every 50 ms
(test/echo_talker.py chatter, SUBNET discovery, UDPv4, dds_env) to one listener in "ground"
(test/netlab_listener.py); after 5 s of discovery, for --seconds, the frames/s the switch
reads (its stats) and its CPU.

Run as root: .venv/bin/python benchmarks/netlab_switch.py [--rates 2000 10000 30000 max]
             [--size 200] [--seconds 3] [--dds-nodes 10]
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from uav_insar_sim.netlab.dds_env import dds_env  # noqa: E402
from uav_insar_sim.netlab.lab import NetLab  # noqa: E402

PORT = 27100
SENDER = """
import socket, sys, time
addr, port, rate = sys.argv[1], int(sys.argv[2]), sys.argv[3]
size, seconds = int(sys.argv[4]), float(sys.argv[5])
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
data, n, t0 = b"x" * size, 0, time.monotonic()
gap = 0.0 if rate == "max" else 1.0 / float(rate)
while (now := time.monotonic()) - t0 < seconds:
    if gap and n * gap > now - t0:
        continue
    s.sendto(data, (addr, port)); n += 1
print(n, flush=True)
"""
COUNTER = """
import socket, sys
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
s.bind(("0.0.0.0", int(sys.argv[1]))); s.settimeout(1.0)
print("ready", flush=True)
n = 0
try:
    while True:
        s.recv(65536); n += 1
except TimeoutError:
    print(n, flush=True)
"""


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def flood(lab: NetLab, rate: str, size: int, seconds: float) -> None:
    counter = lab.start("ground", [sys.executable, "-c", COUNTER, str(PORT)])
    assert counter.stdout.readline().strip() == "ready"
    cpu0, t0 = cpu_seconds(lab.switch_pid()), time.monotonic()
    sender = lab.start("uav0", [sys.executable, "-c", SENDER, lab.address("ground"),
                                str(PORT), rate, str(size), str(seconds)])
    sent = int(sender.communicate(timeout=seconds + 30)[0])
    cpu = cpu_seconds(lab.switch_pid()) - cpu0
    wall = time.monotonic() - t0
    got = int(counter.communicate(timeout=30)[0])
    print(f"rate {rate:>6}/s  sent {sent:7d} ({sent / seconds:8.0f}/s)  received {got:7d} "
          f"({100 * got / sent:5.1f} %)  switch CPU {100 * cpu / wall:5.1f} % of a core")


def dds_load(lab: NetLab, nodes: int, seconds: float) -> None:
    env = dds_env("subnet", base=dict(os.environ, ROS_DOMAIN_ID="205", PYTHONPATH=str(REPO)))
    lab.start("ground", [sys.executable, str(REPO / "test/netlab_listener.py")], env=env)
    for _ in range(nodes):
        lab.start("uav0", [sys.executable, str(REPO / "test/echo_talker.py"), "chatter"],
                  env=env)
    time.sleep(5.0)
    before, cpu0, t0 = json.loads(lab.switch("stats")), cpu_seconds(lab.switch_pid()), \
        time.monotonic()
    time.sleep(seconds)
    after, cpu, wall = json.loads(lab.switch("stats")), cpu_seconds(lab.switch_pid()) - cpu0, \
        time.monotonic() - t0
    frames = sum(after["ports"][p]["rx"] - before["ports"][p]["rx"] for p in after["ports"])
    print(f"DDS: {nodes} talkers + 1 listener: {frames / wall:.0f} frames/s through the "
          f"switch, switch CPU {100 * cpu / wall:.1f} % of a core")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rates", nargs="+", default=["2000", "10000", "30000", "max"])
    p.add_argument("--size", type=int, default=200, help="UDP payload [bytes]")
    p.add_argument("--seconds", type=float, default=3.0)
    p.add_argument("--dds-nodes", type=int, default=10)
    args = p.parse_args()
    with NetLab(["ground", "uav0"]) as lab:
        for rate in args.rates:
            flood(lab, rate, args.size, args.seconds)
        if args.dds_nodes:
            dds_load(lab, args.dds_nodes, args.seconds)


if __name__ == "__main__":
    main()
