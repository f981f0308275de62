"""MAVLink 2 message signing, as ArduPilot and PX4 do it, with the key from a file.

A signed frame carries link_id (1 byte), a 48-bit timestamp in units of 10 us since
2015-01-01 00:00 UTC and the first 6 bytes of SHA-256(key || header || payload || crc ||
link_id || timestamp). A receiver accepts a frame only when the signature matches and, per
stream (link_id, sysid, compid), the timestamp increases strictly; a new stream is accepted
when its timestamp is at most one minute behind the receiver's own (pymavlink's
check_signature, as in the C library). Our own timestamp starts at the wall clock and never
falls behind what we have received, so restarts keep it increasing.

pymavlink's own check records a stream's timestamp before it checks the signature, so one
forged frame with a far-future timestamp would lock the real sender out; `SigningParser`
checks the signature first and only then the timestamp, as the C library does.

Unsigned frames are refused except RADIO_STATUS and RADIO, the radio's own, unsignable
reports (ArduPilot's accept list; it also accepts everything on channel 0, its USB port,
which we have no equivalent of). link_id is the index of the link in its program, as
ArduPilot uses its channel number.

Key file: exactly 32 bytes of raw key, or 64 hexadecimal characters (surrounding whitespace
ignored). `read_key_file` raises ValueError with one line naming the file and what is wrong,
and returns a warning when the file is readable by others.
"""
from __future__ import annotations

import hashlib
import hmac
import os
import stat
import struct
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

KEY_BYTES = 32
MAX_KEY_FILE_BYTES = 4096
SIGNING_EPOCH_UNIX_S = 1420070400  # 2015-01-01 00:00:00 UTC
UNSIGNED_ACCEPTED = frozenset((mavlink2.MAVLINK_MSG_ID_RADIO_STATUS,
                               mavlink2.MAVLINK_MSG_ID_RADIO))


def read_key_file(path: str) -> tuple[bytes, str | None]:
    """(32-byte key, warning or None) from `path` (see the module doc for the format)."""
    where = f"signing key file {path[:120]!r}"
    try:
        with open(path, "rb") as f:
            info = os.fstat(f.fileno())
            if not stat.S_ISREG(info.st_mode):
                raise ValueError(f"{where}: is not a regular file")
            data = f.read(MAX_KEY_FILE_BYTES + 1)
    except OSError as exc:
        raise ValueError(f"{where}: cannot be read ({exc.strerror or exc})") from None
    if len(data) == KEY_BYTES:
        key = data
    else:
        text = data.strip()
        try:
            key = bytes.fromhex(text.decode("ascii")) if len(text) == 2 * KEY_BYTES else b""
        except (UnicodeDecodeError, ValueError):
            key = b""
        if len(key) != KEY_BYTES:
            raise ValueError(f"{where}: holds {len(data)} bytes; expected exactly 32 raw "
                             "bytes or 64 hexadecimal characters")
    if key == bytes(KEY_BYTES):
        raise ValueError(f"{where}: the all-zero key means 'signing off' in MAVLink; "
                         "expected a random key (e.g. head -c 32 /dev/urandom > FILE)")
    warning = None
    if info.st_mode & (stat.S_IRGRP | stat.S_IROTH):
        warning = (f"{where} is readable by group or others (mode "
                   f"{stat.S_IMODE(info.st_mode):o}); chmod 600 it")
    return key, warning


def signing_timestamp(now_unix_s: float | None = None) -> int:
    """The MAVLink signing timestamp for a wall-clock time: 10 us units since 2015-01-01."""
    now = time.time() if now_unix_s is None else now_unix_s
    return int(max(0.0, now - SIGNING_EPOCH_UNIX_S) * 100_000)


def _accept_unsigned(mav: mavlink2.MAVLink, msgid: int) -> bool:
    return msgid in UNSIGNED_ACCEPTED


def signing_state(key: bytes, link_id: int) -> mavlink2.MAVLinkSigning:
    """One signing state (key, our timestamp, the streams seen) for both directions of a
    link: sign everything we send, accept only correctly signed frames (and the radio's)."""
    if len(key) != KEY_BYTES:
        raise ValueError(f"signing key: {len(key)} bytes; expected {KEY_BYTES}")
    if not 0 <= link_id <= 255:
        raise ValueError(f"signing link_id: {link_id!r}; expected 0..255")
    state = mavlink2.MAVLinkSigning()
    state.secret_key = bytes(key)
    state.link_id = link_id
    state.timestamp = signing_timestamp()
    state.sign_outgoing = True
    state.allow_unsigned_callback = _accept_unsigned
    return state


class SigningParser(mavlink2.MAVLink):
    """pymavlink's MAVLink 2 codec with the signature checked before the stream timestamp."""

    def check_signature(self, msgbuf: bytearray, srcSystem: int, srcComponent: int) -> bool:
        s = self.signing
        digest = hashlib.sha256(s.secret_key + bytes(msgbuf[:-6])).digest()[:6]
        if not hmac.compare_digest(digest, bytes(msgbuf[-6:])):
            return False
        low, high = struct.unpack("<IH", bytes(msgbuf[-12:-6]))
        stamp = low + (high << 32)
        stream = (msgbuf[-13], srcSystem, srcComponent)
        last = s.stream_timestamps.get(stream)
        if last is not None and stamp <= last:
            return False  # a replay, or out of order
        if last is None and stamp + 6_000_000 < s.timestamp:
            return False  # a new stream more than a minute old
        s.stream_timestamps[stream] = stamp
        s.timestamp = max(s.timestamp, stamp)
        return True
