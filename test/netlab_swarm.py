"""The swarm across hosts in the network lab, for tests: a ground namespace (planner and
recorder) and one namespace per UAV (`uav-insar-vehicle`, its autopilot on the UAV's own
loopback, with the bridge and the autopilot-position agent in /uavK), joined by the lab's
lossy switch (uav_insar_sim/netlab).

    with open_lab(radio(0.1)) as lab:                 # or: lab = lab_fixture(radio(0.1))
        swarm = start_swarm(lab, domain, tmp_path, "subnet", num_slots=8)
        wait_for(lambda: swarm.out["agent0"].first("mission complete"), 150.0, swarm.procs())
        swarm.stop_recorder()
        bag = read_bag(tmp_path / "bag")

Each NetLab names its namespaces and its /24 after this process and a counter, so labs of
different tests and pytest runs never share a name or an address; every UAV's vehicle may
use the same loopback port.
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import pytest
import yaml

from uav_insar_planner.demo.processes import executable
from uav_insar_planner.param_specs.nodes import FIRST_SYSID
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, uav_name, uav_names, uavs
from uav_insar_sim.mission import home_position
from uav_insar_sim.netlab.dds_env import dds_env
from uav_insar_sim.netlab.lab import LabUnavailable, NetLab

# Table I's swarm (test_num_uavs.py flies others)
UAVS = uavs(DEFAULT_NUM_UAVS)
UAV_NAMES = uav_names(DEFAULT_NUM_UAVS)
VEHICLE_PORT = 14552  # on each UAV's own loopback: every UAV can use the same
VEHICLE_HEIGHT_M = 10.0  # airborne above the agent's home moved beside the track start
POSITION_NOISE_STD_M = 0.3  # the reported position's error per axis, as GNSS under an EKF
FAST_DDS_HEARTBEAT_S = 3.0  # a reliable writer's default heartbeat period
LOG_TIME = re.compile(r"\[(\d+\.\d+)\]")


def radio(loss: float) -> str:
    """The switch's impairment of a UAV's radio link: `loss` each way, 50 ms +- 20 ms."""
    return f"loss={loss:g} delay=0.05 jitter=0.02"


RADIO = radio(0.1)  # the documented radio (docs/hardware.md): 10 % loss


def base_env() -> dict[str, str]:
    """This process's environment with unbuffered Python output (lines as they come)."""
    return {**os.environ, "PYTHONUNBUFFERED": "1"}


class Output:
    """Reads a process's output lines as they come, with the wall time each arrived."""

    def __init__(self, proc: subprocess.Popen, name: str) -> None:
        self.proc, self.name = proc, name
        self.lines: list[tuple[float, str]] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append((time.time(), line.rstrip()))

    def text(self) -> str:
        return "\n".join(line for _, line in self.lines)

    def first(self, pattern: str, after: float = 0.0) -> float | None:
        """The wall time of the first line matching `pattern` logged after `after`: the
        ROS log line's own stamp where it has one, else its arrival time."""
        for t, line in self.lines:
            if re.search(pattern, line):
                m = LOG_TIME.search(line)
                stamp = float(m[1]) if m else t
                if stamp >= after:
                    return stamp
        return None


def wait_for(done: Callable[[], object], timeout: float,
             procs: Sequence[subprocess.Popen] = ()) -> bool:
    """Polls `done` until true (True), `timeout` s pass or one of `procs` ends (False)."""
    end = time.monotonic() + timeout
    while not done():
        if time.monotonic() > end or any(p.poll() is not None for p in procs):
            return False
        time.sleep(0.1)
    return True


@contextmanager
def open_lab(link: str) -> Iterator[NetLab]:
    """A lab of the ground and every UAV, each UAV's link impaired by `link` (`radio`) from
    the start; the test skips with the lab's reason where it cannot be built."""
    try:
        with NetLab(["ground", *UAV_NAMES]) as net:
            for name in UAV_NAMES:
                net.switch(f"set {name} {link}")
            yield net
    except LabUnavailable as exc:
        pytest.skip(f"no network lab here: {exc}")


def lab_fixture(link: str, name: str = "lab"):
    """A pytest fixture `name` yielding `open_lab(link)` (assign it in the test module)."""

    @pytest.fixture(name=name)
    def _lab() -> Iterator[NetLab]:
        with open_lab(link) as net:
            yield net

    return _lab


class Swarm:
    """The processes of one swarm in `lab`: their Output readers by name (`out`)."""

    def __init__(self, lab: NetLab, domain: int, tmp_path: Path, discovery: str,
                 params: Path) -> None:
        self.lab, self.domain, self.tmp_path = lab, domain, tmp_path
        self.discovery, self.params = discovery, params
        self.out: dict[str, Output] = {}

    def env(self, host: str) -> dict[str, str]:
        addresses = {n: self.lab.address(n) for n in ["ground", *UAV_NAMES]}
        peers = ([a for n, a in addresses.items() if n != host]
                 if self.discovery == "static" else [])
        return dds_env(self.discovery, peers, {**base_env(), "ROS_DOMAIN_ID": str(self.domain)})

    def start(self, host: str, name: str, cmd: list[str]) -> Output:
        proc = self.lab.start(host, cmd, env=self.env(host), stderr=subprocess.STDOUT)
        self.out[name] = Output(proc, name)
        return self.out[name]

    def ros(self) -> list[str]:
        return ["--ros-args", "--params-file", str(self.params)]

    def start_planner(self, name: str = "planner") -> Output:
        """The planner on the ground with the swarm's parameters (again, after a kill)."""
        return self.start("ground", name, [*executable("planner"), *self.ros()])

    def procs(self) -> list[subprocess.Popen]:
        return [o.proc for o in self.out.values()]

    def logs(self, tail: int = 1500) -> str:
        return "\n".join(f"== {n}\n{o.text()[-tail:]}" for n, o in self.out.items())

    def stop_recorder(self) -> None:
        stop_recorder(self.out)


def stop_recorder(out: dict[str, Output]) -> None:
    """SIGINT the recorder (out["recorder"]) so that it closes the bag; the lab kills the
    rest."""
    rec = out["recorder"].proc
    os.killpg(rec.pid, signal.SIGINT)
    rec.wait(timeout=30)
    assert rec.returncode == 0, out["recorder"].text()[-2000:]


def start_swarm(lab: NetLab, domain: int, tmp_path: Path, discovery: str, *,
                num_slots: int = 8, uav_timeout_s: float = 3.0, gcs_timeout_s: float = 3.0,
                noise_std_m: float = POSITION_NOISE_STD_M) -> Swarm:
    """The ground station and every UAV stack, each vehicle airborne beside the track start
    (its home's x, y = 0), its reported position wandering by `noise_std_m` per axis;
    `num_slots` 1 s slots; a bag of what reached the ground in tmp_path/bag."""
    params = tmp_path / "params.yaml"
    params.write_text(yaml.safe_dump({"/**": {"ros__parameters": {
        # the planner's default capture radius: a tighter one waits on the position noise
        "num_slots": num_slots, "slot_duration_s": 1.0, "uav_timeout_s": uav_timeout_s,
        "capture_radius_m": 1.0, "gcs_timeout_s": gcs_timeout_s,
        "velocity_feedforward": True,
        # one slot more than the mission, so every UAV crosses the line after its last slot
        "track_duration_s": float(num_slots + 1)}}}))
    swarm = Swarm(lab, domain, tmp_path, discovery, params)
    for k in UAVS:
        host = uav_name(k)
        x, _, _ = home_position(k)  # beside the track start (y = 0), not behind it
        swarm.start(host, f"vehicle{k}", [
            *executable("uav-insar-vehicle"), "--sysid", str(FIRST_SYSID + k), "--listen",
            f"udpin:127.0.0.1:{VEHICLE_PORT}", "--airborne", "--start-ned", "0", str(x),
            str(-VEHICLE_HEIGHT_M), "--position-noise-std", str(noise_std_m),
            "--noise-seed", str(domain)])
        ns = ["-r", f"__ns:=/{host}", "-p", f"uav_id:={k}"]
        swarm.start(host, f"bridge{k}", [
            *executable("mavlink_bridge"), *swarm.ros(), *ns,
            "-p", f"connections:=['udpout:127.0.0.1:{VEHICLE_PORT}']",
            "-p", f"target_sysids:=[{FIRST_SYSID + k}]"])
        swarm.start(host, f"agent{k}", [*executable("agent"), *swarm.ros(), *ns,
                                        "-p", "position_source:=autopilot"])
    swarm.start_planner()
    swarm.start("ground", "recorder", [*executable("uav-insar"), "record",
                                       str(tmp_path / "bag")])
    return swarm


def read_bag(path: Path) -> dict[str, list]:
    """Every message of the bag at `path` by topic: (receive time [s], message), in order."""
    from rosbags.highlevel import AnyReader

    topics: dict[str, list] = {}
    with AnyReader([path]) as reader:
        for conn, stamp, raw in reader.messages():
            topics.setdefault(conn.topic, []).append(
                (stamp * 1e-9, reader.deserialize(raw, conn.msgtype)))
    return topics


def timeline(out: dict[str, Output], pattern: str, t0: float) -> str:
    """Every line of every process matching `pattern` (a regex), by its log stamp, each
    with its time from `t0` and the process's name: what happened when, across hosts."""
    rows = []
    for name, o in out.items():
        for t, line in o.lines:
            if re.search(pattern, line):
                m = LOG_TIME.search(line)
                rows.append((float(m[1]) if m else t, name, line[line.find("]: ") + 3:]
                             if m else line))
    return "\n".join(f"{t - t0:+8.2f} s {name:>14}: {text[:200]}"
                     for t, name, text in sorted(rows))
