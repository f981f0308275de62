"""`tcp:HOST:PORT` for `link.Link`: a TCP client that connects and reconnects without ever
blocking the one I/O thread every link shares (see TcpClient)."""
from __future__ import annotations

import errno
import socket
import time

#: A dead TCP link is tried again at most this often, each try one non-blocking connect().
TCP_RECONNECT_S = 1.0


class TcpClient:
    """`tcp:HOST:PORT` that never blocks the caller (pymavlink's mavtcp sleeps in connect and,
    with autoreconnect, ~6 s in every reconnect, which would stall every other link).

    The connect is a non-blocking connect(); `recv` finishes it, and after a refusal, reset or
    EOF the socket is closed and tried again at most every TCP_RECONNECT_S. `fd` is the socket's
    descriptor while one exists (it changes on reconnect), else -1. `write` drops the bytes
    while not connected. Attribute `port` is the socket, as in pymavlink.
    """

    def __init__(self, host: str, port: int):
        self.address = (host, port)
        self.port: socket.socket | None = None
        self.connected = False
        self.connects = 0  # completed connections, reconnects included
        self._next_try = 0.0
        self._try_connect()

    @property
    def fd(self) -> int:
        return self.port.fileno() if self.port is not None else -1

    def _try_connect(self) -> None:
        self._next_try = time.monotonic() + TCP_RECONNECT_S
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        code = sock.connect_ex(self.address)
        if code not in (0, errno.EINPROGRESS, errno.EWOULDBLOCK, errno.EALREADY):
            sock.close()
            return
        self.port = sock
        if code == 0:
            self._on_connected()

    def _on_connected(self) -> None:
        self.connected = True
        self.connects += 1

    def _drop(self) -> None:
        if self.port is not None:
            self.port.close()
        self.port, self.connected = None, False
        self._next_try = time.monotonic() + TCP_RECONNECT_S

    def _progress(self) -> bool:
        """Move a pending connect on; True once connected."""
        if self.connected:
            return True
        if self.port is None:
            if time.monotonic() >= self._next_try:
                self._try_connect()
            return self.connected
        error = self.port.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)
        if error == 0:
            try:
                self.port.getpeername()
            except OSError:  # still in progress
                if time.monotonic() >= self._next_try:
                    self._drop()
                return False
            self._on_connected()
            return True
        self._drop()
        return False

    def recv(self, n: int) -> bytes:
        if not self._progress():
            return b""
        try:
            data = self.port.recv(n)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:
            self._drop()
            return b""
        if not data:  # EOF: the peer closed
            self._drop()
        return data

    def write(self, data: bytes) -> None:
        if not self.connected:
            return
        try:
            self.port.sendall(data)
        except (BlockingIOError, InterruptedError):
            raise OSError("TCP send buffer full; message dropped") from None
        except OSError:
            self._drop()
            raise

    def close(self) -> None:
        self._drop()
