"""One MAVLink endpoint: a pymavlink transport plus our own tolerant MAVLink 2 parser.

pymavlink's `mavutil.mavlink_connection` opens the transport (UDP in/out, `tcpin:`, serial,
...; a `tcp:` client is our own `tcp.TcpClient`, which never blocks); we keep its socket
handling but parse and send with a private MAVLink 2 codec, because
mavutil switches the protocol version through a process-wide environment variable and a
module global, which two endpoints in one process must not share.

Malformed input never raises: bad CRC, garbage and bad lengths are counted as `bad_data`,
unknown message ids as `unknown_msgid`; on datagram transports (UDP) a datagram that ends
inside a frame is counted as `truncated` and its tail dropped, so it cannot swallow the next,
valid datagram (MAVLink over UDP carries whole frames per datagram).

With `signing` (signing.signing_state) every frame sent is signed and only correctly signed
frames are returned (the rest counted as `bad_signature`). A message that cannot be packed
(a value outside its wire type) is counted as `unsendable`, never raised. On UDP each
message comes with the address of its datagram (`poll_sources`), and a `udpin` link replies
only to peers that sent at least one valid (and, with signing, signed) message, so garbage
from a stranger does not subscribe it to our traffic, and to at most MAX_UDPIN_PEERS of
them. TCP and serial carry no such address.
A host name is resolved when the link opens (ValueError if it does not resolve).
"""
from __future__ import annotations

import os
import socket
import struct
import time
from dataclasses import dataclass

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from uav_insar_planner.mavlink.signing import SigningParser, read_key_file, signing_state
from uav_insar_planner.mavlink.tcp import TcpClient

#: The MAVLink 2 dialect module (message classes, MAV_* constants) every user of this link
#: shares, so constants and codecs always come from one place.
MAV = mavlink2

_LIVE_PREFIXES = ("udpin:", "udpout:", "udpbcast:", "udp:", "tcp:", "tcpin:", "mcast:",
                  "uds:", "unix:")
_READ_CHUNK = 4096
_UDP_MAX = 65535
MAX_UDPIN_PEERS = 8
_MAX_READS_PER_POLL = 256  # bounds one poll, so a flooded link cannot starve the others


def parse_address(address: str) -> tuple[str, int]:
    """Split a connection string into (device, baud) and reject what is not a live link.

    Accepted: pymavlink's `udpin:HOST:PORT`, `udpout:HOST:PORT`, `udpbcast:`, `udp:`, `tcp:`,
    `tcpin:`, `mcast:`, `uds:`, and serial devices as `DEVICE` or `DEVICE,BAUD` (MAVProxy
    style, default 57600). Log files and CSV readers are refused. Raises ValueError.
    """
    text = address.strip()
    if not text:
        raise ValueError("empty connection string")
    if text.startswith(_LIVE_PREFIXES):
        rest = text.split(":", 1)[1]
        if text.startswith(("udp", "tcp")):
            host, sep, port = rest.rpartition(":")
            if not sep or not port.isdigit() or int(port) > 65535:
                raise ValueError(f"{address!r} needs HOST:PORT after the scheme")
        return text, 57600
    lowered = text.lower()
    if lowered.startswith("csv:") or lowered.endswith((".tlog", ".bin", ".log", ".px4log",
                                                       ".mavlink", ".raw")):
        raise ValueError(f"{address!r} is a log file, not a live MAVLink link")
    device, sep, baud = text.partition(",")
    if sep and not baud.isdigit():
        raise ValueError(f"{address!r}: baud after ',' must be an integer")
    serial_like = device.startswith(("/dev/", "COM", "\\\\.\\"))
    if not serial_like or ":" in device or os.path.isfile(device):
        raise ValueError(f"{address!r} is not a known connection string (udpin:HOST:PORT, "
                         "udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or a serial device "
                         "such as /dev/ttyUSB0,57600)")
    try:
        import serial  # noqa: F401 - pymavlink's serial transport needs pyserial
    except ImportError:
        raise ValueError(f"{address!r}: serial links need pyserial (pip install "
                         "pyserial)") from None
    return device, int(baud) if sep else 57600


Source = tuple  # (host, port) of a UDP datagram


def resolve_host(address: str) -> None:
    """Resolve the host of a udp*/tcp* connection string; ValueError when it does not."""
    text = address.strip()
    if not text.startswith(("udp", "tcp")):
        return
    host, _, port = text.split(":", 1)[1].rpartition(":")
    if host in ("", "0.0.0.0"):
        return
    try:
        socket.getaddrinfo(host, int(port), socket.AF_INET)  # our sockets are IPv4
    except (OSError, UnicodeError) as exc:
        raise ValueError(f"cannot open {address[:120]!r}: host {host[:80]!r} does not "
                         f"resolve ({getattr(exc, 'strerror', None) or exc})") from None


@dataclass
class LinkStats:
    """Counters of one link. The owner keeps `foreign` (traffic from unknown sysids, or not
    from the configured ground station), `spoofed` (heartbeats for a known sysid from an
    unexpected component or address) and `bad_value` (messages with non-finite or
    out-of-range fields, dropped)."""

    rx_bytes: int = 0
    rx_messages: int = 0
    bad_data: int = 0
    truncated: int = 0
    unknown_msgid: int = 0
    foreign: int = 0
    io_errors: int = 0
    tx_messages: int = 0
    bad_signature: int = 0  # unsigned, wrongly signed or replayed (signing on)
    unsendable: int = 0  # outgoing messages whose values do not fit their wire types
    spoofed: int = 0
    bad_value: int = 0

    @property
    def malformed(self) -> int:
        """Everything dropped as not decodable: bad data, truncated frames, unknown ids."""
        return self.bad_data + self.truncated + self.unknown_msgid


class Link:
    """A MAVLink endpoint that sends as (source_system, source_component).

    Not thread-safe: one thread polls and sends. `fileno()` is for select(); `poll()` reads
    everything waiting now and returns the decoded messages, never raising on bad input.
    """

    def __init__(self, address: str, source_system: int, source_component: int,
                 signing: MAV.MAVLinkSigning | None = None):
        device, baud = parse_address(address)
        resolve_host(device)
        self.address = address
        self.source_system = source_system
        self.source_component = source_component
        self.signing = signing
        try:
            if device.startswith("tcp:"):
                host, _, port = device[4:].rpartition(":")
                self.conn = TcpClient(host, int(port))
            else:
                self.conn = mavutil.mavlink_connection(
                    device, baud=baud, source_system=source_system,
                    source_component=source_component)
        except Exception as exc:  # pymavlink raises OSError, ValueError, SerialException...
            raise ValueError(f"cannot open {address!r}: {exc}") from None
        self._datagrams = isinstance(self.conn, (mavutil.mavudp, mavutil.mavmcast))
        self._udp = isinstance(self.conn, mavutil.mavudp)
        #: udpout: the (IP, port) we send to, the only address the peer's replies come from
        self.peer_address: Source | None = None
        if device.startswith("udpout:"):
            host, _, port = device[7:].rpartition(":")
            self.peer_address = (socket.gethostbyname(host), int(port))
        self._tx = MAV.MAVLink(self.conn, srcSystem=source_system, srcComponent=source_component)
        if signing is not None:
            self._tx.signing = signing
        self._rx = self._new_parser()
        self.stats = LinkStats()

    def _new_parser(self) -> MAV.MAVLink:
        codec = MAV.MAVLink if self.signing is None else SigningParser
        parser = codec(None, srcSystem=self.source_system, srcComponent=self.source_component)
        if self.signing is not None:
            parser.signing = self.signing  # one state: our timestamp and the streams seen
        parser.robust_parsing = True
        return parser

    @property
    def mav(self) -> MAV.MAVLink:
        """The encoder; use `send(link.mav.xxx_encode(...))`."""
        return self._tx

    def local_port(self) -> int | None:
        """The bound local UDP/TCP port (tests bind port 0 and ask), or None."""
        sock = getattr(self.conn, "port", None)
        try:
            return sock.getsockname()[1]
        except (AttributeError, OSError, IndexError, TypeError):
            return None

    @property
    def up(self) -> bool:
        """False while a TCP link is (re)connecting; other transports are always up."""
        return getattr(self.conn, "connected", True)

    def fileno(self) -> int | None:
        """The descriptor to select() on, None while there is none (poll then); it may change
        (TCP reconnects), so ask again before each select."""
        if not self.up:
            return None
        fd = getattr(self.conn, "fd", None)
        return fd if isinstance(fd, int) and fd >= 0 else None

    def send(self, msg: MAV.MAVLink_message) -> None:
        """Encode and write one message; a transport error is counted, never raised."""
        try:
            self._tx.send(msg)
            self.stats.tx_messages += 1
        except (OverflowError, struct.error, TypeError):
            self.stats.unsendable += 1  # a value outside its wire type: nothing was written
        except (OSError, ValueError):
            self.stats.io_errors += 1

    def send_raw(self, data: bytes) -> None:
        """Write bytes as they are (tests use it to inject malformed frames)."""
        try:
            self.conn.write(data)
        except (OSError, ValueError):
            self.stats.io_errors += 1

    def poll(self) -> list[MAV.MAVLink_message]:
        """Read what is waiting now; return the valid messages in arrival order."""
        return [msg for msg, _ in self.poll_sources()]

    def poll_sources(self) -> list[tuple[MAV.MAVLink_message, Source | None]]:
        """Like `poll`, each message with the (host, port) it came from (UDP; else None)."""
        out: list[tuple[MAV.MAVLink_message, Source | None]] = []
        for _ in range(_MAX_READS_PER_POLL):
            try:
                data, source = self._recv()
            except (OSError, ValueError):
                self.stats.io_errors += 1
                break
            if not data:
                break
            self.stats.rx_bytes += len(data)
            msgs = self._feed(bytes(data) if not isinstance(data, str)
                              else data.encode("latin-1"))
            if msgs and source is not None and self.conn.udp_server:
                self._add_udpin_peer(source)
            out += [(m, source) for m in msgs]
        return out

    def _add_udpin_peer(self, source: Source) -> None:
        """pymavlink's udpin sends to every client it has heard, for ever: keep the
        MAX_UDPIN_PEERS heard most recently, so many senders cannot grow it (nor our sends)."""
        clients, alive = self.conn.clients, self.conn.clients_last_alive
        clients.add(source)
        alive[source] = time.time()
        while len(clients) > MAX_UDPIN_PEERS:
            oldest = min(clients, key=lambda a: alive.get(a, 0.0))
            clients.discard(oldest)
            alive.pop(oldest, None)

    def _recv(self) -> tuple[bytes, Source | None]:
        if not self._udp:
            return self.conn.recv(_READ_CHUNK), None
        try:
            data, source = self.conn.port.recvfrom(_UDP_MAX)
        except (BlockingIOError, InterruptedError, ConnectionRefusedError):
            return b"", None  # nothing waiting; a refused udpout send reports here
        if self.conn.broadcast:
            self.conn.last_address = source
        return data, source

    def _feed(self, data: bytes) -> list[MAV.MAVLink_message]:
        out = []
        msg = self._rx.parse_char(data)
        while msg is not None:
            kind = msg.get_type()
            if kind == "BAD_DATA":
                if "signature" in str(getattr(msg, "reason", "")):
                    self.stats.bad_signature += 1
                else:
                    self.stats.bad_data += 1
            elif kind.startswith("UNKNOWN_"):
                self.stats.unknown_msgid += 1
            else:
                self.stats.rx_messages += 1
                out.append(msg)
            msg = self._rx.parse_char(b"")
        if self._datagrams and self._rx.buf_len() > 0:
            self.stats.truncated += 1
            self._rx = self._new_parser()
        return out

    def close(self) -> None:
        try:
            self.conn.close()
        except (OSError, ValueError):
            pass


def open_links(addresses: list[str], sysid: int, compid: int, key_file: str
               ) -> tuple[dict[str, Link], str]:
    """One Link per distinct address, every one signing with the key of `key_file` (""
    unsigned), as (links by address, the key file's warning or ""); ValueError naming the
    parameter (signing_key_file or connections), with every link opened so far closed."""
    key, warning = None, ""
    if key_file:
        try:
            key, warning = read_key_file(key_file)
        except ValueError as exc:
            raise ValueError(f"signing_key_file: {exc}") from None
    links: dict[str, Link] = {}
    try:
        for i, address in enumerate(dict.fromkeys(addresses)):
            links[address] = Link(address, sysid, compid,
                                  None if key is None else signing_state(key, link_id=i))
    except ValueError as exc:
        for link in links.values():
            link.close()
        raise ValueError(f"connections: {exc}") from None
    return links, warning or ""
