"""The network lab (uav_insar_sim/netlab): real namespaces, real TAP devices, the real switch
process, real UDP and real rclpy processes across it. Every lab test skips with the lab's
reason where namespaces or TAP devices are not permitted (not root, no /dev/net/tun)."""
from __future__ import annotations

import json
import math
import queue
import statistics
import subprocess
import sys
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor

import process_group
import pytest
from conftest import REPO

from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_CRASH
from uav_insar_sim.netlab.dds_env import dds_env
from uav_insar_sim.netlab.impair import Direction, LinkSpec
from uav_insar_sim.netlab.lab import (
    IFNAME,
    NEIGH_SOLICIT_KEYS,
    NEIGH_SOLICITS,
    LabUnavailable,
    NetLab,
)

UDP = str(REPO / "test" / "netlab_udp.py")
PORT = "27010"


@pytest.fixture
def lab():
    try:
        with NetLab(["ground", "uav0"]) as built:
            yield built
    except LabUnavailable as exc:
        pytest.skip(str(exc))


def udp_trial(lab: NetLab, count: int, gap: float = 0.002) -> dict[int, float]:
    """`count` datagrams from uav0 to ground; {seq: one-way delay [s]} of those received."""
    recv = lab.start("ground", [sys.executable, UDP, "recv", PORT, "1.0"])
    assert recv.stdout.readline().strip() == "listening"
    send = lab.start("uav0", [sys.executable, UDP, "send", lab.address("ground"), PORT,
                              str(count), str(gap)])
    assert send.wait(timeout=30) == 0
    out, err = recv.communicate(timeout=30)
    assert recv.returncode == 0, err
    return {int(k): v for k, v in json.loads(out).items()}


def binomial_bounds(n: int, p: float, sigmas: float = 4.5) -> tuple[float, float]:
    sd = math.sqrt(n * p * (1 - p))
    return n * p - sigmas * sd, n * p + sigmas * sd


def test_udp_loss_delay_jitter_then_cut_restore_clear(lab):
    assert len(udp_trial(lab, 20)) == 20  # a perfect link (and the ARP entries are made)
    assert lab.switch("set uav0 dir=in loss=0.1 delay=0.05 jitter=0.02") == "ok"
    n = 1000
    got = udp_trial(lab, n)
    low, high = binomial_bounds(n, 0.1)
    assert low <= n - len(got) <= high, n - len(got)
    delays = sorted(got.values())
    assert statistics.mean(delays) == pytest.approx(0.050, abs=0.005)
    # Uniform on 30..70 ms: a standard deviation of 20 ms / sqrt(3); the machine adds a
    # millisecond of scheduling, a loaded one a few more at the top.
    assert 0.029 <= delays[0] and delays[int(0.95 * len(delays))] <= 0.072
    assert statistics.stdev(delays) == pytest.approx(0.02 / math.sqrt(3), rel=0.3)
    stats = json.loads(lab.switch("stats"))["ports"]
    assert stats["uav0"]["dropped_in"] >= n - len(got) and stats["uav0"]["dropped_out"] == 0
    assert stats["uav0"]["in"]["loss"] == 0.1 and stats["uav0"]["out"]["loss"] == 0.0

    assert lab.switch("cut uav0") == "ok"
    assert udp_trial(lab, 200) == {}
    assert lab.switch("restore uav0") == "ok"  # the cut goes, the 10 % loss stays
    low, high = binomial_bounds(200, 0.1)
    assert low <= 200 - len(udp_trial(lab, 200)) <= high
    assert lab.switch("clear uav0") == "ok"
    got = udp_trial(lab, 200)
    assert len(got) == 200 and max(got.values()) < 0.02


def test_arp_keeps_trying_a_neighbour_over_the_lossy_port(lab):
    """Each namespace's eth0 sends NEIGH_SOLICITS unicast and broadcast ARP probes before it
    gives a neighbour up (3 by default: at 30 % loss each way a CI run's ground lost a UAV
    for 3.3 s, `ip monitor neigh` showed 2 of 14 re-confirmations FAILED in 240 s; none of
    15 with 10)."""
    assert NEIGH_SOLICITS >= 10
    for name in ("ground", "uav0"):
        for key in NEIGH_SOLICIT_KEYS:
            got = subprocess.run([*lab.prefix(name), "sysctl", "-n",
                                  f"net.ipv4.neigh.{IFNAME}.{key}"],
                                 capture_output=True, text=True, check=True).stdout
            assert int(got) == NEIGH_SOLICITS, (name, key, got)


def test_the_impairment_is_reproducible_from_its_seed():
    def fates(seed: int) -> list[float | None]:
        d = Direction(seed, "uav0", "in")
        d.spec = LinkSpec(loss=0.3, delay=0.05, jitter=0.02, dist="normal")
        return [d.fate() for _ in range(500)]

    assert fates(7) == fates(7) and fates(7) != fates(8)
    kept = [f for f in fates(7) if f is not None]
    assert 0.0 <= min(kept) and max(kept) <= 0.1 and 300 < len(kept) < 400


BAD_COMMANDS = [
    ("", "command"), ("frobnicate uav0", "'frobnicate'"), ("set", "needs a port"),
    ("set uav9 loss=0.1", "'uav9'"), ("set uav0 loss=1.5", "loss=1.5"),
    ("set uav0 loss=nan", "loss='nan'"), ("set uav0 delay=-1", "delay=-1"),
    ("set uav0 delay=0.01 jitter=0.02", "jitter=0.02"), ("set uav0 dist=pareto", "'pareto'"),
    ("set uav0 dir=up", "dir='up'"), ("cut uav0 loss=1", "'loss=1'"),
    ("stats now", "'now'"), ("set uav0 loss", "'loss'"),
]


def test_bad_control_commands_are_refused_with_one_line_and_change_nothing(lab):
    before = json.loads(lab.switch("stats"))["ports"]
    for command, named in BAD_COMMANDS:
        reply = lab.switch(command)
        assert reply.startswith("error: ") and "\n" not in reply, (command, reply)
        assert named in reply and ("allowed" in reply or "needs" in reply), (command, reply)
    after = json.loads(lab.switch("stats"))["ports"]
    for port in before:
        assert (after[port]["in"], after[port]["out"]) == (before[port]["in"],
                                                           before[port]["out"])


def test_bad_switch_arguments_exit_2_with_one_line():
    for args in (["--port", "ground"], ["--port", "a=way-too-long-ifname0"],
                 ["--port", "a=x", "--port", "a=y"]):
        done = process_group.run([sys.executable, "-m", "uav_insar_sim.netlab.switch",
                               "--control", "/nonexistent/ctl", *args], cwd=REPO,
                              capture_output=True, text=True, timeout=30)
        assert done.returncode == EXIT_BAD_INPUT, done
        assert len(done.stderr.splitlines()) == 1 and "--port" in done.stderr, done.stderr


def test_a_port_that_vanishes_kills_the_switch_with_exit_1(lab):
    process_group.run(["ip", "-n", lab.namespaces["uav0"], "link", "del", "eth0"], check=True)
    deadline = time.monotonic() + 10
    while lab.switch_exit_code() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert lab.switch_exit_code() == EXIT_CRASH
    err = lab._switch.stderr.read()
    assert len(err.splitlines()) == 1 and "port uav0" in err, err


# -- rclpy across the lab ----------------------------------------------------------------------
def chatter(lab: NetLab, env_ground: dict, env_uav: dict) -> queue.Queue:
    """A listener in ground and a talker (String every 50 ms) in uav0; the queue of the
    listener's "got ..." lines."""
    lines: queue.Queue = queue.Queue()
    listener = lab.start("ground", [sys.executable, str(REPO / "test/netlab_listener.py")],
                         env=env_ground)

    def pump() -> None:
        for line in listener.stdout:
            if line.startswith("got "):
                lines.put(line.strip())

    threading.Thread(target=pump, daemon=True).start()
    lab.start("uav0", [sys.executable, str(REPO / "test/echo_talker.py"), "chatter"],
              env=env_uav)
    return lines


def received(lines: queue.Queue, seconds: float) -> int:
    """How many messages arrive within `seconds`."""
    deadline, n = time.monotonic() + seconds, 0
    while (left := deadline - time.monotonic()) > 0:
        try:
            lines.get(timeout=left)
            n += 1
        except queue.Empty:
            break
    return n


def first_within(lines: queue.Queue, seconds: float) -> bool:
    try:
        lines.get(timeout=seconds)
        return True
    except queue.Empty:
        return False


def ros_env(**overlay: str) -> dict:
    import os

    env = dict(os.environ, PYTHONPATH=str(REPO), PYTHONUNBUFFERED="1")
    env.pop("FASTDDS_BUILTIN_TRANSPORTS", None)
    env.update(overlay)
    return env


@pytest.mark.parametrize("transports", ["dds_env", "fast_dds_default"])
def test_subnet_discovery_across_the_switch_and_a_cut_stops_it(lab, ros_domain, transports):
    """SPDP multicast crosses the switch; cutting uav0 stops the messages: no shared-memory
    path around the switch, with dds_env (UDPv4 only) and with Fast DDS's default
    transports (SHM + UDPv4) alike."""
    env = dds_env("subnet", base=ros_env())
    if transports == "fast_dds_default":
        del env["FASTDDS_BUILTIN_TRANSPORTS"]
    lines = chatter(lab, env, env)
    assert first_within(lines, 15), "no message over SUBNET discovery"
    stats = json.loads(lab.switch("stats"))["ports"]
    assert stats["ground"]["rx_multicast"] > 0 and stats["uav0"]["rx_multicast"] > 0
    assert lab.switch("cut uav0") == "ok"
    received(lines, 0.5)  # what was on its way
    assert received(lines, 2.0) == 0
    assert lab.switch("restore uav0") == "ok"
    assert received(lines, 3.0) > 10  # 20 Hz, reliable: it resumes


def test_static_peers_with_multicast_off(lab, ros_domain):
    """LOCALHOST range + ROS_STATIC_PEERS: discovered by unicast, not one multicast frame."""
    lines = chatter(lab, dds_env("static", [lab.address("uav0")], base=ros_env()),
                    dds_env("static", [lab.address("ground")], base=ros_env()))
    assert first_within(lines, 15), "no message with static peers"
    stats = json.loads(lab.switch("stats"))["ports"]
    assert stats["ground"]["rx_multicast"] == 0 and stats["uav0"]["rx_multicast"] == 0


NOTHING_CASES = ("static_without_peers", "range_off_with_peers", "other_domain")


def listen_for_nothing(case: str, domain: int, another_domain: int) -> tuple[int, dict | None]:
    """test_nothing_is_discovered's `case` in a lab of its own, the ground on `domain`: how
    many messages arrived in 6 s, and the switch's port stats (None for other_domain)."""

    def env(**overlay: str) -> dict:
        """ros_env as in a test with conftest's ros_domain fixture, then `overlay`."""
        base = ros_env(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        base.pop("ROS_STATIC_PEERS", None)
        return {**base, **overlay}

    with NetLab(["ground", "uav0"]) as lab:
        if case == "static_without_peers":
            env_ground = env_uav = dds_env("static", base=env())
        elif case == "range_off_with_peers":
            peers = f"{lab.address('ground')};{lab.address('uav0')}"
            env_ground = env_uav = env(ROS_AUTOMATIC_DISCOVERY_RANGE="OFF",
                                       ROS_STATIC_PEERS=peers,
                                       FASTDDS_BUILTIN_TRANSPORTS="UDPv4")
        else:
            env_ground = dds_env("subnet", base=env())
            env_uav = dds_env("subnet", base=env(ROS_DOMAIN_ID=str(another_domain)))
        lines = chatter(lab, env_ground, env_uav)
        n = received(lines, 6.0)
        stats = json.loads(lab.switch("stats"))["ports"] if case != "other_domain" else None
    return n, stats


@pytest.fixture(scope="module")
def undiscovered() -> dict[str, Future]:
    """Every case of test_nothing_is_discovered, each in a lab of its own, listened to side
    by side (each is 6 s of silence to wait out): case -> the future of its outcome."""
    from conftest import _next_domain

    with ThreadPoolExecutor(len(NOTHING_CASES)) as pool:
        return {case: pool.submit(listen_for_nothing, case, _next_domain(), _next_domain())
                for case in NOTHING_CASES}


@pytest.mark.parametrize("case", NOTHING_CASES)
def test_nothing_is_discovered(undiscovered, case):
    """Multicast off and no peers: nothing. Range OFF ignores the static peers (so OFF is not
    the way to multicast-free discovery). Another ROS_DOMAIN_ID on the same SUBNET: nothing."""
    try:
        n, stats = undiscovered[case].result()
    except LabUnavailable as exc:
        pytest.skip(str(exc))
    assert n == 0
    if case != "other_domain":
        assert stats["ground"]["rx_multicast"] == 0 and stats["uav0"]["rx_multicast"] == 0


def test_the_lab_touches_nothing_outside_and_tears_down_after_an_exception():
    dead = "nl999999x0-ground"  # a lab namespace of a process that no longer exists
    process_group.run(["ip", "netns", "add", dead], capture_output=True)
    lab = NetLab(["ground", "uav0"])
    try:
        with pytest.raises(RuntimeError, match="a failing test"), lab:
            names = process_group.run(["ip", "netns", "list"], capture_output=True,
                                   text=True).stdout
            assert dead not in names and all(ns in names for ns in lab.namespaces.values())
            root = process_group.run(["ip", "-4", "addr"], capture_output=True, text=True).stdout
            root += process_group.run(["ip", "-4", "route", "show", "table", "all"],
                                   capture_output=True, text=True).stdout
            assert lab.subnet + "." not in root
            sleeper = lab.start("uav0", ["sleep", "600"])
            raise RuntimeError("a failing test")
    except LabUnavailable as exc:
        pytest.skip(str(exc))
    finally:
        process_group.run(["ip", "netns", "del", dead], capture_output=True)
    assert sleeper.poll() is not None
    names = process_group.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    assert not any(ns in names for ns in lab.namespaces.values())
    assert lab.switch_exit_code() is not None
