"""NetLab: named Linux network namespaces, each with one port of a lossy switch (switch.py).

    with NetLab(["ground", "uav0"]) as lab:
        lab.start("uav0", [sys.executable, "talker.py"], env=...)   # runs inside uav0
        lab.switch("set uav0 loss=0.1 delay=0.05 jitter=0.02")
        lab.address("ground")                                       # "10.a.b.1"

Each namespace (named `<run>-<name>`, `<run>` unique to this process and lab) holds `lo`
and `eth0`, the TAP device of its switch port, with an address from a /24 private to the run
and a route for multicast (224.0.0.0/4, DDS discovery) on eth0. IPv6 is off on eth0, so the
switch carries only what the processes send (no router solicitations, no MLD), and ARP tries
NEIGH_SOLICITS times before it gives a neighbour up. Nothing is
added to the root namespace: no address, no route. On exit, even after an exception, the
processes the lab started are killed by process group, then the switch (its TAPs vanish with
it), then the namespaces are deleted.

Where namespaces or TAP devices are not permitted, entering raises LabUnavailable with the
reason (a test skips with it).
"""
from __future__ import annotations

import itertools
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path

from uav_insar_sim.netlab import control
from uav_insar_sim.netlab.tap import TUN_PATH

IFNAME = "eth0"  # the port's interface inside every namespace
MULTICAST_ROUTE = "224.0.0.0/4"
# ARP over the lossy port, as docs/hardware.md advises for the radio: every ~50 s a neighbour
# entry in use is re-confirmed by unicast probes, 3 by default before it is dropped and
# resolved again by broadcast, 3 more. At 30 % loss each way a probe and its reply both pass
# with probability 0.49, so 3 all fail 13 % of the time, and unicast to that host (DDS data:
# the ground's heartbeats, a UAV's poses) then stops until one passes: a CI run's bridge held
# on 3.3 s of silence that way. With 10 each, 0.51^10 = 1e-3 of them fail.
NEIGH_SOLICIT_KEYS = ("ucast_solicit", "mcast_solicit")
NEIGH_SOLICITS = 10
READY_TIMEOUT_S = 10.0
STOP_TIMEOUT_S = 5.0
_runs = itertools.count()
_RUN_NAMESPACE = re.compile(r"nl(\d+)x\d+-\S+")


class LabUnavailable(Exception):
    """This machine (or user) cannot build the lab; str(self) says why."""


def _run(*cmd: str) -> None:
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode:
        raise RuntimeError(f"{' '.join(cmd)}: {' '.join(done.stderr.split())}")


def _kill_group(proc: subprocess.Popen, timeout: float = STOP_TIMEOUT_S) -> None:
    """SIGTERM the process group of `proc`, SIGKILL after `timeout`."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        if proc.poll() is not None:
            break
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            continue
    try:  # the group may outlive its leader
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    proc.wait()


class NetLab:
    """Namespaces `names`, one switch port each; a context manager (module docstring)."""

    def __init__(self, names: Sequence[str], seed: int = 0) -> None:
        if len(set(names)) != len(names) or not names or not all(
                re.fullmatch(r"[A-Za-z0-9_]{1,32}", n) for n in names):
            raise ValueError(f"names {list(names)!r} not allowed: one or more, all different, "
                             "each 1..32 of A-Z a-z 0-9 _")
        n = next(_runs)
        self.run_id = f"nl{os.getpid()}x{n}"
        net = (os.getpid() * 8 + n) % (250 * 256)  # the /24: 10.<a>.<b>.0, a in 1..250
        self.subnet = f"10.{1 + net // 256}.{net % 256}"
        self.names = list(names)
        self.seed = seed
        self.namespaces = {name: f"{self.run_id}-{name}" for name in names}
        self._made: list[str] = []
        self._procs: list[subprocess.Popen] = []
        self._switch: subprocess.Popen | None = None
        self._tmp: tempfile.TemporaryDirectory | None = None
        self.control_path = ""

    # -- what tests use --------------------------------------------------------------------
    def address(self, name: str) -> str:
        """The IPv4 address of namespace `name` on the lab's network."""
        return f"{self.subnet}.{self.names.index(name) + 1}"

    def prefix(self, name: str) -> list[str]:
        """The command prefix that runs a program inside namespace `name`."""
        return ["ip", "netns", "exec", self.namespaces[name]]

    def start(self, name: str, cmd: Sequence[str], env: Mapping[str, str] | None = None,
              **popen: object) -> subprocess.Popen:
        """Start `cmd` inside namespace `name` in a session of its own (killed at exit);
        stdout and stderr are pipes (text) unless `popen` says otherwise."""
        popen = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True, **popen}
        proc = subprocess.Popen([*self.prefix(name), *cmd], env=dict(env or os.environ),
                                start_new_session=True, **popen)
        self._procs.append(proc)
        return proc

    def stop(self, proc: subprocess.Popen) -> None:
        """Kill `proc` (started by `start`) and its process group now."""
        _kill_group(proc)

    def switch(self, command: str) -> str:
        """Send a control command to the switch (control.py); its reply."""
        return control.send(self.control_path, command)

    # -- building and tearing down -----------------------------------------------------------
    def __enter__(self) -> NetLab:
        reason = self._unavailable()
        if reason:
            raise LabUnavailable(reason)
        try:
            self._build()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @staticmethod
    def _unavailable() -> str:
        if not sys.platform.startswith("linux"):
            return f"network namespaces need Linux, this is {sys.platform}"
        if shutil.which("ip") is None:
            return "the `ip` command (iproute2) is not installed"
        if not os.access(TUN_PATH, os.R_OK | os.W_OK):
            return f"{TUN_PATH} is missing or not usable (no TAP devices)"
        if os.geteuid() != 0:
            return "network namespaces and TAP devices need root (CAP_NET_ADMIN, CAP_SYS_ADMIN)"
        return ""

    def _build(self) -> None:
        _sweep_dead_runs()
        self._tmp = tempfile.TemporaryDirectory(prefix=f"{self.run_id}-")
        self.control_path = str(Path(self._tmp.name) / "switch.sock")
        taps = {name: f"{self.run_id}t{k}" for k, name in enumerate(self.names)}
        for name in self.names:
            ns = self.namespaces[name]
            done = subprocess.run(["ip", "netns", "add", ns], capture_output=True, text=True)
            if done.returncode:
                raise LabUnavailable(f"`ip netns add {ns}` is not permitted here: "
                                     f"{' '.join(done.stderr.split())}")
            self._made.append(ns)
        self._start_switch(taps)
        for name in self.names:
            ns, ip = self.namespaces[name], ("ip", "-n", self.namespaces[name])
            _run("ip", "link", "set", taps[name], "netns", ns)
            _run(*ip, "link", "set", taps[name], "name", IFNAME)
            _run(*self.prefix(name), "sysctl", "-qw", f"net.ipv6.conf.{IFNAME}.disable_ipv6=1",
                 *(f"net.ipv4.neigh.{IFNAME}.{key}={NEIGH_SOLICITS}"
                   for key in NEIGH_SOLICIT_KEYS))
            _run(*ip, "addr", "add", f"{self.address(name)}/24", "dev", IFNAME)
            _run(*ip, "link", "set", "lo", "up")
            _run(*ip, "link", "set", IFNAME, "up")
            _run(*ip, "route", "add", MULTICAST_ROUTE, "dev", IFNAME)

    def _start_switch(self, taps: Mapping[str, str]) -> None:
        ports = [f"--port={name}={tap}" for name, tap in taps.items()]
        self._switch = subprocess.Popen(
            [sys.executable, "-m", "uav_insar_sim.netlab.switch", "--control",
             self.control_path, "--seed", str(self.seed), *ports],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            start_new_session=True, env=dict(os.environ, PYTHONPATH=_pythonpath()))
        line = self._switch.stdout.readline()  # "ready", or "" when it died
        if line.strip() != "ready":
            _kill_group(self._switch)
            why = " ".join(self._switch.stderr.read().split())
            raise RuntimeError(f"the switch did not start: {why}")

    def switch_pid(self) -> int:
        """The switch's process id (for a benchmark's CPU figures)."""
        return self._switch.pid

    def switch_exit_code(self) -> int | None:
        """The switch's exit code if it has ended (a crash is EXIT_CRASH), else None."""
        return self._switch.poll() if self._switch else None

    def close(self) -> None:
        """Kill what the lab started, delete its namespaces; safe to call twice."""
        for proc in self._procs:
            _kill_group(proc)
        if self._switch is not None:
            _kill_group(self._switch)
        for ns in self._made:
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)
        self._made.clear()
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None


def _sweep_dead_runs() -> None:
    """Delete the namespaces of labs whose process is gone (killed before it could clean
    up, e.g. SIGKILL by a test timeout); those of live processes are left alone."""
    listing = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    for line in listing.splitlines():
        match = _RUN_NAMESPACE.match(line.split(" ", 1)[0])
        if match and not Path(f"/proc/{match.group(1)}").exists():
            subprocess.run(["ip", "netns", "del", match.group(0)], capture_output=True)


def _pythonpath() -> str:
    """PYTHONPATH for the switch: this source tree first (it may not be installed)."""
    root = str(Path(__file__).resolve().parents[2])
    return os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH", "")) if p)
