"""Test helper: records an ArduPilot SITL vehicle's physics truth to a CSV file, from a
MAVLink port of its own (not the bridge's), e.g. SERIAL1 `tcp:127.0.0.1:5762` inside the UAV's
namespace.

    python simstate_recorder.py HOST:PORT OUT.csv [--rate-hz 10] [--param NAME ...]

It connects (retrying while SITL boots: SERIAL1 listens only once SERIAL0 has its client),
asks for SIMSTATE (164) and SIM_STATE (108) with MAV_CMD_SET_MESSAGE_INTERVAL (again every
second until they come), and writes one row per SIMSTATE:

    t_wall_s,lat_e7,lng_e7,alt_m

t_wall_s is time.time() at arrival (the same clock as the ROS stamps on this machine),
lat_e7/lng_e7 SIMSTATE's (1e-7 deg); SIMSTATE has no altitude, so alt_m is the AMSL altitude of
the latest SIM_STATE (ArduPilot sends the two together, from the same physics state). Runs
until killed; each row is flushed as it is written. Each --param is read back once
(PARAM_REQUEST_READ, again every second until answered) into OUT.csv.params as `NAME VALUE`
lines: what the simulator actually runs with.
"""
from __future__ import annotations

import argparse
import socket
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink

MAV_CMD_SET_MESSAGE_INTERVAL = 511
SOURCE_SYSID, SOURCE_COMPID = 250, 191  # not the bridge's 255: a second ground station
HEADER = "t_wall_s,lat_e7,lng_e7,alt_m"


def connect(host: str, port: int) -> socket.socket:
    """A connected TCP socket, tried every 0.5 s until the port listens."""
    while True:
        try:
            return socket.create_connection((host, port), timeout=2.0)
        except OSError:
            time.sleep(0.5)


def request(mav: mavlink.MAVLink, sysid: int, interval_us: int) -> None:
    for msgid in (mavlink.MAVLINK_MSG_ID_SIMSTATE, mavlink.MAVLINK_MSG_ID_SIM_STATE):
        mav.command_long_send(sysid, 1, MAV_CMD_SET_MESSAGE_INTERVAL, 0, msgid, interval_us,
                              0, 0, 0, 0, 0)


def record(address: str, out_path: str, rate_hz: float, params: list[str]) -> None:
    host, port = address.rsplit(":", 1)
    sock = connect(host, int(port))
    sock.settimeout(1.0)
    mav = mavlink.MAVLink(sock.makefile("wb", buffering=0), SOURCE_SYSID, SOURCE_COMPID)
    mav.robust_parsing = True
    interval_us = round(1e6 / rate_hz)
    sysid, alt_m, asked, rows = 0, None, 0.0, 0
    unread = list(params)
    with open(out_path, "w", buffering=1) as out, \
            open(out_path + ".params", "w", buffering=1) as read_back:
        out.write(HEADER + "\n")
        while True:
            if sysid and (unread or not rows) and time.monotonic() - asked > 1.0:
                if not rows:
                    request(mav, sysid, interval_us)
                for name in unread:
                    mav.param_request_read_send(sysid, 1, name.encode(), -1)
                asked = time.monotonic()
            try:
                data = sock.recv(4096)
            except TimeoutError:
                continue
            if not data:
                raise SystemExit(f"{address}: connection closed after {rows} rows")
            for msg in mav.parse_buffer(data) or ():
                kind = msg.get_type()
                if kind == "HEARTBEAT" and not sysid:
                    sysid = msg.get_srcSystem()
                elif kind == "PARAM_VALUE" and msg.param_id in unread:
                    unread.remove(msg.param_id)
                    read_back.write(f"{msg.param_id} {msg.param_value:g}\n")
                elif kind == "SIM_STATE":
                    alt_m = msg.alt
                elif kind == "SIMSTATE" and alt_m is not None:
                    out.write(f"{time.time():.6f},{msg.lat},{msg.lng},{alt_m:.4f}\n")
                    rows += 1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("address", help="HOST:PORT of a SITL MAVLink TCP port")
    parser.add_argument("out", help="CSV file to write")
    parser.add_argument("--rate-hz", type=float, default=10.0)
    parser.add_argument("--param", action="append", default=[], help="read back NAME")
    args = parser.parse_args()
    record(args.address, args.out, args.rate_hz, args.param)


if __name__ == "__main__":
    main()
