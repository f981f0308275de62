"""`uav-insar start-missions --at HH:MM:SS CONNECTION...`: send MAV_CMD_MISSION_START to every
vehicle at one UTC instant, each over its own MAVLink link (mavlink/mission_start.py).

This is how PX4 UAVs flying `uav-insar export-mission --autopilot px4` files start their passes
together: each holds at its pass start (PX4 ignores NAV_DELAY's UTC time) until MISSION_START
with first item `--item` (default: the pass's first item in those files). ArduPilot's files
wait for their NAV_DELAY time instead (ArduCopter refuses a MISSION_START with a first item).
Each CONNECTION is one vehicle's link, as the bridge's `connections` take them (udpin:, udpout:,
tcp:, tcpin:, a serial device[,BAUD]); its vehicle is the first autopilot heard on it. The
instant is on this computer's clock: keep it NTP- or GNSS-synced. Every argument is checked,
and every link opened, before anything is sent. Exit codes (exit_codes.py): EXIT_OK when every
vehicle ACCEPTED (or at SIGINT before the instant: nothing sent), EXIT_BAD_INPUT, EXIT_CRASH
when a vehicle was not heard within 3 s of the instant (then nothing is sent) or did not ACCEPT.
"""
from __future__ import annotations

import argparse
import time
from datetime import datetime, timezone

from uav_insar_planner.cli.checks import utc_instant
from uav_insar_planner.exit_codes import EXIT_CRASH, EXIT_OK
from uav_insar_planner.mavlink.link import Link, parse_address
from uav_insar_planner.mavlink.mission_start import HEARD_WITHIN_S, start_missions
from uav_insar_planner.mission_file.qgc_plan import PX4_PASS_SEQ
from uav_insar_planner.params import ParamError, shown

HELP = "start every UAV's mission at one UTC instant (MISSION_START; PX4's common start)"
LEAN = True  # pymavlink only: it runs on a lean install (extras.py), a field laptop's
ITEM_MAX = 65535  # a mission sequence number is a uint16
SYSID_MAX = 255


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("connections", nargs="+", metavar="CONNECTION",
                        help="one vehicle's MAVLink link each: udpin:HOST:PORT, "
                        "udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or /dev/ttyUSB0,57600")
    parser.add_argument("--at", required=True, metavar="HH:MM:SS|ISO",
                        help="the instant (UTC; HH:MM:SS is today), in the next 24 h")
    parser.add_argument("--item", default=str(PX4_PASS_SEQ), metavar="SEQ",
                        help=f"MISSION_START's first item (default {PX4_PASS_SEQ}: where "
                        "export-mission's PX4 files start the pass)")
    parser.add_argument("--source-sysid", default="255", metavar="ID",
                        help="our own MAVLink system id, 1..255 (default 255, a ground station)")


def integer_option(option: str, text: str, lo: int, hi: int) -> int:
    """`text` as an integer in lo..hi, else one ParamError line naming `option`."""
    stripped = text.strip()
    if not (stripped.lstrip("+-").isdigit() and len(stripped) <= 12
            and lo <= int(stripped) <= hi):
        raise ParamError([f"{option}: value {shown(text)} is not allowed; expected an integer "
                          f"in {lo}..{hi}"])
    return int(stripped)


def open_connections(addresses: list[str], source_sysid: int) -> list[Link]:
    """Every link (as a ground station of `source_sysid`), or ParamError naming the first bad
    one, `CONNECTION i` (the ones opened are closed)."""
    for i, address in enumerate(addresses, 1):
        try:
            parse_address(address)
        except ValueError as exc:
            raise ParamError([f"CONNECTION {i}: value {shown(address)} is not allowed; "
                              f"{exc}"]) from None
    links: list[Link] = []
    try:
        for i, address in enumerate(addresses, 1):
            try:
                links.append(Link(address, source_sysid, 190))  # MAV_COMP_ID_MISSIONPLANNER
            except ValueError as exc:
                raise ParamError([f"CONNECTION {i}: {exc}"]) from None
    except ParamError:
        for link in links:
            link.close()
        raise
    return links


def main(args: argparse.Namespace) -> int:
    now = datetime.now(timezone.utc)
    instant = utc_instant("--at", args.at, now)
    item = integer_option("--item", args.item, 0, ITEM_MAX)
    sysid = integer_option("--source-sysid", args.source_sysid, 1, SYSID_MAX)
    if len(set(args.connections)) != len(args.connections):
        raise ParamError(["CONNECTION: a link is given twice; expected one per vehicle"])
    links = open_connections(args.connections, sysid)
    t0 = instant.timestamp()
    print(f"starting {len(links)} vehicle(s) at {instant:%Y-%m-%dT%H:%M:%SZ} from item {item}",
          flush=True)
    try:
        outcomes = start_missions(links, t0, item)
    except KeyboardInterrupt:
        before = time.time() < t0
        print("interrupted " + ("before the instant: nothing sent" if before else
                                "after the instant: some vehicles may have started"))
        return EXIT_OK if before else EXIT_CRASH
    finally:
        for link in links:
            link.close()
    if not any(o.sent_at for o in outcomes):
        print(f"nothing sent: not every vehicle was heard within {HEARD_WITHIN_S:g} s of the "
              "instant")
    for outcome in outcomes:
        print(outcome.describe(t0))
    return EXIT_OK if all(o.accepted for o in outcomes) else EXIT_CRASH
