"""A learning Ethernet switch in user space between TAP devices, with per-port impairment.

    python -m uav_insar_sim.netlab.switch --control PATH [--seed N] --port LABEL=IFNAME ...

opens one TAP device IFNAME per port (in this network namespace; move it elsewhere with
`ip link set IFNAME netns NS`, the switch keeps its fd), binds the control socket PATH
(control.py), prints "ready" and forwards until SIGINT / SIGTERM. Broadcast, multicast (DDS
discovery) and unknown destinations are flooded to every other port; unicast goes to the
port its source MAC was last seen on. A frame from port A to port B meets A's "in" and then
B's "out" impairment (impair.py): lost if either loses it, delayed by the sum.

One thread does everything (epoll on the TAPs, the control socket and a signal pipe), so a
failure of the forwarding is the process's: one line on stderr, exit EXIT_CRASH. A write the
kernel refuses (EIO: the port's interface is down) is counted, not fatal.
Exit codes: EXIT_OK at SIGINT / SIGTERM, EXIT_BAD_INPUT for bad arguments (nothing opened),
EXIT_CRASH when a TAP could not be opened or the forwarding failed.
"""
from __future__ import annotations

import errno
import heapq
import itertools
import json
import os
import select
import signal
import socket
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict

from uav_insar_planner.cli.parser import OneLineParser
from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_CRASH, EXIT_OK
from uav_insar_sim.netlab import control
from uav_insar_sim.netlab.impair import Direction, LinkSpec
from uav_insar_sim.netlab.tap import check_ifname, open_tap

PROG = "uav-insar-netswitch"
FRAME_MAX_BYTES = 65536
IPV4_MULTICAST_MAC = b"\x01\x00\x5e"  # RFC 1112: 01:00:5e + the group's low 23 bits
READ_BATCH = 64  # frames read from one port before the others get their turn


class Port:
    """One TAP device, its two impairment directions and its counters."""

    def __init__(self, label: str, ifname: str, seed: int) -> None:
        self.label, self.ifname = label, ifname
        self.fd = open_tap(ifname)
        self.dirs = {d: Direction(seed, label, d) for d in ("in", "out")}
        self.stats = dict.fromkeys(("rx", "rx_multicast", "tx", "dropped_in",
                                    "dropped_out", "write_errors"), 0)

    def report(self) -> dict[str, object]:
        """The counters, and the impairment of each direction (for `stats`)."""
        return {**self.stats, **{d: asdict(v.spec) for d, v in self.dirs.items()}}

    def write(self, frame: bytes) -> None:
        try:
            os.write(self.fd, frame)
            self.stats["tx"] += 1
        except OSError as exc:
            if exc.errno not in (errno.EIO, errno.EAGAIN, errno.ENOBUFS):
                raise OSError(f"port {self.label} ({self.ifname}): write failed: {exc}") from exc
            self.stats["write_errors"] += 1


class Switch:
    """The ports, the MAC table, the queue of delayed frames and the control socket."""

    def __init__(self, ports: Sequence[tuple[str, str]], control_path: str,
                 seed: int = 0) -> None:
        self.ports: dict[str, Port] = {}
        try:
            for label, ifname in ports:
                self.ports[label] = Port(label, ifname, seed)
            self.ctl = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
            self.ctl.bind(control_path)
        except BaseException:
            self.close()
            raise
        self.by_fd = {p.fd: p for p in self.ports.values()}
        self.macs: dict[bytes, Port] = {}
        self.queue: list[tuple[float, int, Port, bytes]] = []
        self._seq = itertools.count()

    def close(self) -> None:
        for port in self.ports.values():
            os.close(port.fd)
        if hasattr(self, "ctl"):
            self.ctl.close()

    def forward(self, src: Port, frame: bytes, now: float) -> None:
        """Send `frame`, read from `src` at `now`, where it goes, through the impairments."""
        src.stats["rx"] += 1
        if len(frame) < 14:
            return  # not Ethernet
        if frame.startswith(IPV4_MULTICAST_MAC):
            src.stats["rx_multicast"] += 1
        delay_in = src.dirs["in"].fate()
        if delay_in is None:
            src.stats["dropped_in"] += 1
            return
        self.macs[frame[6:12]] = src
        known = None if frame[0] & 1 else self.macs.get(frame[0:6])
        targets = [known] if known is not None else self.ports.values()
        for dst in targets:
            if dst is src:
                continue
            delay_out = dst.dirs["out"].fate()
            if delay_out is None:
                dst.stats["dropped_out"] += 1
            elif delay_in + delay_out <= 0.0:
                dst.write(frame)
            else:
                heapq.heappush(self.queue, (now + delay_in + delay_out, next(self._seq),
                                            dst, frame))

    def read_port(self, port: Port) -> None:
        now = time.monotonic()
        for _ in range(READ_BATCH):
            try:
                frame = os.read(port.fd, FRAME_MAX_BYTES)
            except BlockingIOError:
                return
            except OSError as exc:
                raise OSError(f"port {port.label} ({port.ifname}): read failed: {exc}") from exc
            self.forward(port, frame, now)

    def release_due(self) -> float:
        """Write every delayed frame now due; seconds until the next one (-1: none)."""
        now = time.monotonic()
        while self.queue and self.queue[0][0] <= now:
            _, _, dst, frame = heapq.heappop(self.queue)
            dst.write(frame)
        return self.queue[0][0] - now if self.queue else -1.0

    def command(self, line: str) -> str:
        """The reply to control command `line` (control.py); a refused one changes nothing."""
        try:
            cmd = control.parse(line, list(self.ports))
            if cmd.verb == "stats":
                return json.dumps({"ports": {k: p.report() for k, p in self.ports.items()},
                                   "queued": len(self.queue)})
            dirs = [self.ports[cmd.port].dirs[d] for d in cmd.directions]
            fields = {"set": cmd.fields, "cut": {"cut": True}, "restore": {"cut": False},
                      "clear": {}}[cmd.verb]
            specs = [LinkSpec() if cmd.verb == "clear" else d.spec.updated(**fields)
                     for d in dirs]
        except ValueError as exc:
            return f"error: {' '.join(str(exc).split())}"
        for direction, spec in zip(dirs, specs, strict=True):
            direction.spec = spec
        return "ok"

    def serve_control(self) -> None:
        while True:
            try:
                data, addr = self.ctl.recvfrom(control.MAX_COMMAND_BYTES)
            except BlockingIOError:
                return
            reply = self.command(data.decode(errors="replace"))
            if addr:
                try:
                    self.ctl.sendto(reply.encode(), addr)
                except OSError:
                    pass  # the client gave up waiting; the command has been applied

    def run(self, wake_fd: int) -> None:
        """Forward until a byte arrives on `wake_fd` (the signal pipe)."""
        self.ctl.setblocking(False)
        poller = select.epoll()
        for fd in (*self.by_fd, self.ctl.fileno(), wake_fd):
            poller.register(fd, select.EPOLLIN)
        timeout = -1.0
        while True:
            for fd, _ in poller.poll(timeout):
                if fd == wake_fd:
                    return
                if fd == self.ctl.fileno():
                    self.serve_control()
                else:
                    self.read_port(self.by_fd[fd])
            timeout = self.release_due()


def _port_arg(text: str) -> tuple[str, str]:
    label, eq, ifname = text.partition("=")
    if not eq or not label:
        raise ValueError(f"--port {text!r} not allowed: LABEL=IFNAME")
    try:
        return label, check_ifname(ifname)
    except ValueError as exc:
        raise ValueError(f"--port {text!r}: {exc}") from None


def main(argv: list[str] | None = None) -> int:
    """Run the switch until SIGINT / SIGTERM; the exit code (module docstring)."""
    p = OneLineParser(prog=PROG, description="A lossy user-space switch between TAP devices.")
    p.add_argument("--port", action="append", required=True, metavar="LABEL=IFNAME",
                   help="a port: its label (control commands) and TAP device name")
    p.add_argument("--control", required=True, help="path of the control socket to bind")
    p.add_argument("--seed", type=int, default=0, help="seed of the impairment RNGs")
    args = p.parse_args(argv)
    try:
        ports = [_port_arg(a) for a in args.port]
        if len({label for label, _ in ports}) < len(ports) or len(
                {ifname for _, ifname in ports}) < len(ports):
            raise ValueError(f"--port {' '.join(args.port)!r} not allowed: labels and "
                             "interface names must be unique")
    except ValueError as exc:
        p.exit(EXIT_BAD_INPUT, f"{PROG}: error: {exc}\n")
    try:
        switch = Switch(ports, args.control, args.seed)
    except OSError as exc:
        print(f"{PROG}: error: cannot open the ports: {exc}", file=sys.stderr, flush=True)
        return EXIT_CRASH
    wake_r, wake_w = os.pipe()
    os.set_blocking(wake_w, False)
    signal.set_wakeup_fd(wake_w)
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: None)
    print("ready", flush=True)
    try:
        switch.run(wake_r)
    except Exception as exc:  # the forwarding died: so does the switch, loudly
        print(f"{PROG}: error: forwarding failed: {' '.join(str(exc).split())}",
              file=sys.stderr, flush=True)
        return EXIT_CRASH
    finally:
        switch.close()
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
