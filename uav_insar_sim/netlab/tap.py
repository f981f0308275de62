"""Open a TAP device: an Ethernet interface whose frames the holder of the fd reads and
writes. The device exists as long as the fd is open (not persistent), in whatever network
namespace it is moved to, so a switch that dies takes its ports with it."""
from __future__ import annotations

import fcntl
import os
import re
import struct

TUN_PATH = "/dev/net/tun"
TUNSETIFF = 0x400454CA  # _IOW('T', 202, int)
IFF_TAP = 0x0002
IFF_NO_PI = 0x1000  # frames only, no 4-byte packet-information header
IFNAMSIZ = 16
IFNAME = re.compile(r"[A-Za-z0-9_.-]{1,15}")


def check_ifname(name: str) -> str:
    """`name` if it is a valid Linux interface name, else ValueError naming it."""
    if not IFNAME.fullmatch(name):
        raise ValueError(f"interface name {name!r} not allowed: 1..15 of A-Z a-z 0-9 _ . -")
    return name


def open_tap(name: str) -> int:
    """Create TAP device `name` in this network namespace; its fd, non-blocking.
    OSError (e.g. EPERM without CAP_NET_ADMIN, EBUSY if it exists) propagates."""
    fd = os.open(TUN_PATH, os.O_RDWR | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        ifr = struct.pack(f"{IFNAMSIZ}sH", check_ifname(name).encode(), IFF_TAP | IFF_NO_PI)
        fcntl.ioctl(fd, TUNSETIFF, ifr.ljust(40, b"\0"))
    except BaseException:
        os.close(fd)
        raise
    return fd
