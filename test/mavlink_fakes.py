"""Test helper: a bare MAVLink peer on a real loopback UDP socket, encoding and decoding with
pymavlink's MAVLink 2 codec. It records everything it receives, can send heartbeats at a
rate (switchable, to fake a link loss) and can write arbitrary bytes (malformed frames).
`custom_mode` / `armed` are what its heartbeat says; `respond(peer, msg)`, if given, is called
(in the peer's thread) for every message it receives, to script an autopilot."""
from __future__ import annotations

import socket
import threading
import time

from pymavlink.dialects.v20 import ardupilotmega as MAV


class _Out:
    def __init__(self, peer: FakePeer):
        self.peer = peer

    def write(self, buf: bytes) -> None:
        self.peer.send_raw(bytes(buf))


class FakePeer:
    """A UDP MAVLink endpoint on 127.0.0.1:<free port>. `dest` is where it sends: given, or
    the address of the first datagram it receives (like pymavlink's udpin)."""

    def __init__(self, sysid: int, compid: int = 1, dest: tuple[str, int] | None = None,
                 heartbeat_hz: float = 0.0, mav_type: int = MAV.MAV_TYPE_QUADROTOR,
                 autopilot: int = MAV.MAV_AUTOPILOT_ARDUPILOTMEGA, custom_mode: int = 4,
                 respond=None):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.02)
        self.port = self.sock.getsockname()[1]
        self.dest = dest
        self.mav = MAV.MAVLink(_Out(self), srcSystem=sysid, srcComponent=compid)
        self.parser = MAV.MAVLink(None)
        self.parser.robust_parsing = True
        self.heartbeat_hz = heartbeat_hz
        self.heartbeats_on = True
        self.mav_type, self.autopilot = mav_type, autopilot
        self.custom_mode, self.armed, self.respond = custom_mode, False, respond
        self.received: list[tuple[float, MAV.MAVLink_message]] = []
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def send_raw(self, data: bytes) -> None:
        if self.dest is not None:
            self.sock.sendto(data, self.dest)

    def heartbeat(self) -> None:
        flags = MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (
            MAV.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
        self.mav.send(self.mav.heartbeat_encode(self.mav_type, self.autopilot, flags,
                                                self.custom_mode, MAV.MAV_STATE_ACTIVE))

    def _run(self) -> None:
        next_hb = time.monotonic()
        while not self._stop.is_set():
            try:
                data, addr = self.sock.recvfrom(65536)
            except TimeoutError:
                data = b""
            except OSError:
                return
            if data:
                if self.dest is None:
                    self.dest = addr
                msgs = self.parser.parse_buffer(data) or []
                with self.lock:
                    now = time.monotonic()
                    self.received += [(now, m) for m in msgs]
                if self.respond is not None:
                    for m in msgs:
                        self.respond(self, m)
            now = time.monotonic()
            if self.heartbeat_hz > 0 and now >= next_hb:
                next_hb = now + 1.0 / self.heartbeat_hz
                if self.heartbeats_on and self.dest is not None:
                    self.heartbeat()

    def messages(self, kind: str, since: float = 0.0) -> list[tuple[float, MAV.MAVLink_message]]:
        with self.lock:
            return [(t, m) for t, m in self.received if m.get_type() == kind and t >= since]

    def wait_for(self, kind: str, timeout: float = 5.0, since: float = 0.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            found = self.messages(kind, since)
            if found:
                return found[-1][1]
            time.sleep(0.01)
        raise AssertionError(f"no {kind} within {timeout} s")

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.sock.close()


def wait_until(predicate, timeout: float, step: float = 0.02) -> bool:
    """Poll `predicate` until it is true or `timeout` seconds pass; return its last value."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(step)
    return bool(predicate())
