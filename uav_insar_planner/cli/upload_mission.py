"""`uav-insar upload-mission PLAN CONNECTION [PLAN CONNECTION ...]`: upload each QGroundControl
`.plan` to the vehicle on its link over MAVLink's mission protocol and check it back
(mavlink/mission_upload.py): download after the upload, every item compared with the file.

The arguments are pairs, each a `.plan` (as `uav-insar export-mission` or `survey` write them)
and then the link of the vehicle that flies it, in the syntax of `start-missions`' and the
bridge's connections (udpin:, udpout:, tcp:, tcpin:, a serial device[,BAUD]); its vehicle is
the first autopilot HEARTBEAT heard on it, and must be the plan's firmware (PX4 or ArduPilot).
Every file is read and checked (mission_file/plan_items.py) and every link opened before
anything is sent; then the vehicles are served one after the other, each whatever the others
did. One line per vehicle: on stdout when its mission was uploaded and checked back, else on
stderr, naming the file, the link and why. Exit codes (exit_codes.py): EXIT_OK when every
mission was uploaded and checked back, EXIT_BAD_INPUT (one line naming the argument or the
file's field, before a byte is sent), EXIT_CRASH when any vehicle failed (not heard, another
firmware, a refusal, silence after TRIES tries, a check-back that differs).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from uav_insar_planner.cli.start_missions import SYSID_MAX, integer_option, open_connections
from uav_insar_planner.exit_codes import EXIT_CRASH, EXIT_OK
from uav_insar_planner.mavlink.mission_upload import Peer, TransferFailed, upload_and_check
from uav_insar_planner.mission_file.plan_items import PlanMission, read_plan
from uav_insar_planner.params import ParamError, shown

HELP = "upload each UAV's .plan over MAVLink's mission protocol and check it back"
LEAN = True  # pymavlink only: it runs on a lean install (extras.py), a field laptop's


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("pairs", nargs="+", metavar="PLAN CONNECTION",
                        help="pairs: a .plan file, then the MAVLink link of the vehicle that "
                        "flies it (udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, "
                        "tcpin:HOST:PORT or /dev/ttyUSB0,57600)")
    parser.add_argument("--source-sysid", default="255", metavar="ID",
                        help="our own MAVLink system id, 1..255 (default 255, a ground station)")


def _pairs(words: list[str]) -> list[tuple[str, str]]:
    if len(words) % 2:
        raise ParamError([f"PLAN CONNECTION: value {shown(' '.join(words))} is not allowed; "
                          f"{len(words)} arguments, expected pairs: a .plan, then its "
                          "vehicle's link (uav0.plan udpin:0.0.0.0:14540 uav1.plan ...)"])
    pairs = list(zip(words[::2], words[1::2], strict=True))
    links = [link for _, link in pairs]
    if len(set(links)) != len(links):
        raise ParamError(["CONNECTION: a link is given twice; expected one per vehicle"])
    return pairs


def main(args: argparse.Namespace) -> int:
    pairs = _pairs(args.pairs)
    sysid = integer_option("--source-sysid", args.source_sysid, 1, SYSID_MAX)
    missions: list[PlanMission] = [read_plan(Path(plan), f"PLAN {i} ({plan})")
                                   for i, (plan, _) in enumerate(pairs, 1)]
    links = open_connections([link for _, link in pairs], sysid)
    failed = 0
    try:
        for (plan, address), mission, link in zip(pairs, missions, links, strict=True):
            try:
                done = upload_and_check(Peer(link), mission)
            except TransferFailed as exc:
                failed += 1
                print(f"uav-insar upload-mission: error: {plan} -> {address}: {exc}",
                      file=sys.stderr, flush=True)
                continue
            note = f" ({done.note})" if done.note else ""
            print(f"{plan} -> {address} (sysid {done.sysid}, {mission.autopilot}): "
                  f"{done.items} items uploaded and checked back{note}", flush=True)
    finally:
        for link in links:
            link.close()
    return EXIT_CRASH if failed else EXIT_OK
