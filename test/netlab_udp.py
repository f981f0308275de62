"""UDP probe for test_netlab.py: numbered, time-stamped datagrams between two namespaces.

    netlab_udp.py recv PORT QUIET          print "listening", receive until QUIET seconds pass
                                           without a datagram, then print one JSON line
                                           {seq: one-way delay [s]}
    netlab_udp.py send ADDR PORT COUNT GAP send COUNT datagrams, GAP seconds apart

The one-way delay is receive time minus send time on CLOCK_MONOTONIC, one clock for every
network namespace of the machine.
"""
from __future__ import annotations

import json
import socket
import struct
import sys
import time

STAMP = struct.Struct("!Id")


def recv(port: int, quiet: float) -> None:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("0.0.0.0", port))
    sock.settimeout(quiet)
    print("listening", flush=True)
    delays: dict[int, float] = {}
    while True:
        try:
            data = sock.recv(2048)
        except TimeoutError:
            break
        seq, sent = STAMP.unpack_from(data)
        delays[seq] = time.monotonic() - sent
    print(json.dumps(delays), flush=True)


def send(addr: str, port: int, count: int, gap: float) -> None:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    for seq in range(count):
        sock.sendto(STAMP.pack(seq, time.monotonic()).ljust(64, b"\0"), (addr, port))
        time.sleep(gap)


if __name__ == "__main__":
    if sys.argv[1] == "recv":
        recv(int(sys.argv[2]), float(sys.argv[3]))
    else:
        send(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]))
