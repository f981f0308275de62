"""A stack per UAV (issue 19, parts 1 and 3), on real processes on localhost: the planner, three
`uav-insar-vehicle` simulators, three `mavlink_bridge` nodes each flying one UAV in its own
namespace (/uavK, `uav_id`), an agent in /uav1; claims refuse a second bridge for one UAV
before it sends a byte; the planner's one wall-clock start starts every bridge's pass.

Ports 29000-29999 (this file's own), a private ROS domain per test (conftest `ros_domain`).
"""
from __future__ import annotations

import os
import socket
import subprocess
import time

import numpy as np
import process_group
import pytest
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from uav_insar_planner.demo.processes import executable, start_process
from uav_insar_planner.params import params_from_mapping
from uav_insar_planner.published import formation_points
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.mavlink_bridge import POSE_PERIOD_S
from uav_insar_planner.ros.start_msgs import decode_start
from uav_insar_planner.solver import solve
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, MAX_UAVS, uavs
from uav_insar_planner.track.passes import run_in_m

# Table I's swarm: this test is of three UAVs (test_num_uavs.py flies others)
UAVS = uavs(DEFAULT_NUM_UAVS)

pytestmark = pytest.mark.timeout(120)
SPEED = 4.3  # the bridges' default speed_mps (Table I v_y)
RUN_IN = run_in_m(SPEED)  # each UAV waits at its entry, this far before its start point
RUN_IN_S = RUN_IN / SPEED  # what the run-in adds to the time to any line past the start
SETPOINT_RATE_HZ = 10.0  # the bridges' default
VEHICLE_PORTS = (29010, 29020, 29030)
SYSIDS = (2, 3, 4)


def start(name: str, *args: str) -> subprocess.Popen:
    """Executable `name` with `args`, in a session of its own (killed by its group)."""
    return start_process([*executable(name), *args], dict(os.environ, PYTHONUNBUFFERED="1"))


def stop(proc: subprocess.Popen) -> str:
    """Ctrl-C its process group, SIGKILL after 8 s; its output."""
    process_group.interrupt_group(proc)
    return proc.stdout.read()


def bridge(k: int, connection: str, sysid: int, *more: str, ns: str | None = None
           ) -> subprocess.Popen:
    """The per-UAV bridge of UAV k in namespace /uavK (or `ns`)."""
    return start("mavlink_bridge", "--ros-args", "-r", f"__ns:={ns or f'/uav{k}'}",
                 "-p", f"uav_id:={k}", "-p", f"connections:=['{connection}']",
                 "-p", f"target_sysids:=[{sysid}]", *more)


def errors(out: str) -> list[str]:
    return [line for line in out.splitlines() if "ERROR" in line]


def progress(samples: list, t0: float, lo: float, hi: float) -> float:
    """Mean of y - v_y (t - t0) over the pose samples (t, y) with lo <= t - t0 <= hi: the
    along-track offset of a UAV cruising since the pass start t0 (its lag behind the target)."""
    ys = [y - SPEED * (t - t0) for t, y in samples if lo <= t - t0 <= hi]
    assert len(ys) >= 10, f"{len(ys)} poses in the window"
    return float(np.mean(ys))


def test_three_stacks_fly_the_formation_and_start_the_pass_together(watcher):
    points = formation_points(solve(params_from_mapping({})))  # what the planner will plan
    vehicles = [start("uav-insar-vehicle", "--sysid", str(s), "--listen",
                      f"udpin:127.0.0.1:{port}", "--airborne", "--speed", "10", "--accel", "5",
                      "--start-ned", str(y - 3.0), str(x), str(-z))  # 3 m short of the start
                for (x, y, z), s, port in zip(points, SYSIDS, VEHICLE_PORTS, strict=True)]
    bridges = [bridge(k, f"udpout:127.0.0.1:{port}", s, "-p", "velocity_feedforward:=true")
               for k, s, port in zip(UAVS, SYSIDS, VEHICLE_PORTS, strict=True)]
    agent = start("agent", "--ros-args", "-r", "__ns:=/uav1", "-p", "uav_id:=1")
    planner = start("planner", "--ros-args")
    starts: list[Header] = []
    watcher.node.create_subscription(Header, "/" + topics.FORMATION_START, starts.append,
                                     topics.LATCHED)
    track: dict[int, list[tuple[float, float]]] = {k: [] for k in UAVS}

    def tracked() -> None:  # (stamp, along-track y) per UAV, from /uavK/mavlink/pose
        for k in UAVS:
            for msg in watcher.mavlink_poses[k][len(track[k]):]:
                track[k].append((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9,
                                 msg.pose.position.y))

    everyone = [*vehicles, *bridges, agent, planner]
    try:
        assert watcher.spin_until(lambda: starts, 40.0, everyone), "no formation/start"
        plan_id, t0, _ = decode_start(starts[0], time.time())
        assert 0.5 < t0 - time.time() < 2.5  # a little in the future: start_delay_s 2
        assert watcher.spin_until(lambda: time.time() > t0 + 4.0 + RUN_IN_S, 10.0, everyone)
        tracked()
        # a re-plan during the pass (same y_start): the same instant under the new identity
        assert watcher.call(Trigger, "/planner/replan", Trigger.Request()).success
        # (the planner sends each start again every half second: look for another label)
        replanned = watcher.spin_until(
            lambda: any(m.frame_id != starts[0].frame_id for m in starts), 20.0, everyone)
        watcher.spin_until(lambda: time.time() > t0 + 6.0 + RUN_IN_S, 10.0, everyone)
        replanned_y = [watcher.mavlink_poses[k][-1].pose.position.y for k in UAVS]
        names = set(watcher.node.get_node_names_and_namespaces())
        flown = list(watcher.flown_plans[1])
        formations = list(watcher.formations)
        diagnostics = [s for m in watcher.diagnostics for s in m.status]
    finally:
        outs = [stop(p) for p in everyone]
    bridge_outs = outs[len(vehicles):len(vehicles) + len(bridges)]
    assert replanned, f"no second start after the re-plan: {outs[-1][-3000:]}"
    # the documented names, whichever way the nodes were started
    assert {("mavlink_bridge", f"/uav{k}") for k in UAVS} | {("agent", "/uav1"),
                                                             ("planner", "/")} <= names
    assert formations and watcher.poses[1], "no /formation or no /uav1/pose"
    assert {s.name for s in diagnostics if s.name.startswith("mavlink_bridge")} == {
        f"mavlink_bridge: uav{k}" for k in UAVS}
    again, t_again, _ = decode_start(
        next(m for m in starts if m.frame_id != starts[0].frame_id), time.time())
    assert t_again == t0 and again != plan_id and again.planner == plan_id.planner
    assert flown[-2:] == [plan_id.label, again.label], flown  # the agent flies /formation
    for k, out in enumerate(bridge_outs):
        assert f"pass start from the planner ({plan_id.label})" in out, out
        assert "formation established" not in out  # no capture gate of its own
        assert "new track start" not in out  # the pass went on
        assert f"pass start from the planner ({again.label})" not in out
        assert replanned_y[k] > track[k][-1][1] + 4.0, (replanned_y, track[k][-1])
    lags = []
    for k in UAVS:
        before = [y for t, y in track[k] if t < t0 - 0.2]
        # waiting at its entry, the start of its run-in, until the pass started
        assert before and max(abs(y - points[k][1] + RUN_IN) for y in before[-5:]) < 1.0, \
            before[-5:]
        assert track[k][-1][1] > 8.0, track[k][-1]  # flew the track: ~4 s at 4.3 m/s
        lags.append(progress(track[k], t0, 1.5, 4.0))
    spread = max(lags) - min(lags)
    # Each bridge sends its target at its own 10 Hz phase (up to one period, v / rate, apart)
    # and each pose is stamped when the bridge polls it (up to POSE_PERIOD_S late, per UAV).
    bound = SPEED / SETPOINT_RATE_HZ + 2 * SPEED * POSE_PERIOD_S
    print(f"along-track spread at the start: {spread:.3f} m (lags {np.round(lags, 3)} m, "
          f"bound {bound:.2f} m)")
    assert spread < bound, lags


class Counter:
    """A UDP port in this file's range that stands for a vehicle: counts what arrives."""

    def __init__(self, port: int):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", port))
        self.sock.setblocking(False)
        self.port, self.bytes = port, 0

    def poll(self) -> int:
        while True:
            try:
                self.bytes += len(self.sock.recv(65536))
            except BlockingIOError:
                return self.bytes


# A MAVLink 2 HEARTBEAT: 10-byte header, 9-byte payload, 2-byte checksum, unsigned.
HEARTBEAT_BYTES = 21


def test_a_second_bridge_for_a_flown_uav_is_refused_within_discovery(ros_domain):
    """A bridge for a UAV another bridge flies is refused with one line naming it. It sends
    nothing when it hears the older claim within its 3 s discovery window. When discovery
    is slower, as seen under CI load, it is refused as soon as the claim arrives (claims.py).
    By then it has sent one heartbeat per link. The flying one killed (SIGKILL), a bridge
    started in its place is granted: a dead writer sends no latched claim."""
    first_port, *others = [Counter(p) for p in (29101, 29102, 29103, 29104, 29105)]
    first = bridge(1, f"udpout:127.0.0.1:{first_port.port}", 3)
    try:
        end = time.monotonic() + 30.0
        while first_port.poll() == 0 and time.monotonic() < end:
            time.sleep(0.1)  # its heartbeats: it passed its discovery window and flies
        assert first_port.bytes > 0, "the first bridge never sent"
        # one after the other: started together, each may see the other's (younger than the
        # first's, still older than its own) claim before the first's, and name that one
        twin = bridge(1, f"udpout:127.0.0.1:{others[0].port}", 3)  # same UAV, same name
        codes = [twin.wait(timeout=30)]
        all_in_one = start("mavlink_bridge", "--ros-args", "-p", "connections:=[" + ", ".join(
            f"'udpout:127.0.0.1:{c.port}'" for c in others[1:]) + "]")
        codes.append(all_in_one.wait(timeout=30))
        outs = [stop(p) for p in (twin, all_in_one)]
        assert first.poll() is None  # the older one keeps flying
        sent = first_port.poll()
        time.sleep(1.5)
        assert first_port.poll() > sent
        process_group.kill_group(first)
        killed_at = time.monotonic()
        sent = others[0].poll()  # the twin's, refused
        refused_bytes = [sent] + [c.poll() for c in others[1:]]
        replacement = bridge(1, f"udpout:127.0.0.1:{others[0].port}", 3)
        while others[0].poll() <= sent + 2 * HEARTBEAT_BYTES and time.monotonic() < end + 30:
            time.sleep(0.1)
        granted_after = time.monotonic() - killed_at
        assert replacement.poll() is None and others[0].poll() > sent + 2 * HEARTBEAT_BYTES
        replacement_out = stop(replacement)
    finally:
        first_out = stop(first)
    assert "no other bridge claims it" in replacement_out, replacement_out
    print(f"a bridge started in place of a SIGKILLed one flies {granted_after:.1f} s later")
    assert codes == [2, 2], outs
    for out in outs:
        lines = errors(out)
        assert len(lines) == 1, out
        assert "uav1: refused, already flown by /uav1/mavlink_bridge" in lines[0]
    # no MAVLink byte, or the heartbeats of the second before a late claim refused it
    assert all(b <= 2 * HEARTBEAT_BYTES for b in refused_bytes), refused_bytes
    assert not errors(first_out), first_out


@pytest.mark.parametrize("args,field", [
    (("-p", f"uav_id:={MAX_UAVS}"), "uav_id"),  # beyond the largest swarm
    (("-p", "uav_id:=-2"), "uav_id"),
    (("-p", "uav_id:=1", "-p", "target_sysids:=[3, 4]"), "target_sysids"),
    (("-r", "__ns:=/uav2", "-p", "uav_id:=1"), "namespace"),
])
def test_a_bad_stack_is_refused_with_one_line(args, field, ros_domain):
    proc = start("mavlink_bridge", "--ros-args", *args)
    try:
        assert proc.wait(timeout=30) == 2
    finally:
        out = stop(proc)
    lines = errors(out)
    assert len(lines) == 1 and field in lines[0], out
