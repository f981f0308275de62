"""`uav-insar-vehicle` (and `python -m uav_insar_sim.vehicle`): run one simulated vehicle
(vehicle/simulator.py) until SIGINT / SIGTERM.

Exit codes (uav_insar_planner/exit_codes.py): EXIT_OK at a clean stop, EXIT_BAD_INPUT for bad
arguments (one line on stderr, before the vehicle starts), EXIT_CRASH when the vehicle loop
died (one line naming why).
"""
from __future__ import annotations

import argparse
import signal
import sys
import threading

from uav_insar_planner.cli.parser import OneLineParser
from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_CRASH, EXIT_OK
from uav_insar_planner.mavlink.signing import read_key_file
from uav_insar_sim.vehicle import estimate_error
from uav_insar_sim.vehicle.profiles import SIMULATED
from uav_insar_sim.vehicle.simulator import SimVehicle
from uav_insar_sim.vehicle.telemetry import SITL_HOME, parse_home

PROG = "uav-insar-vehicle"


def build_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog=PROG,
        description="A SITL-style MAVLink multicopter (ArduPilot-like or PX4-like).")
    p.add_argument("--sysid", type=int, required=True, help="MAVLink system id, 1..255")
    p.add_argument("--listen", required=True,
                   help="pymavlink connection string, e.g. udpin:127.0.0.1:14552 (wait for "
                        "the bridge) or udpout:127.0.0.1:14550 (talk to it)")
    p.add_argument("--autopilot", choices=SIMULATED, default="ardupilot",
                   help="heartbeat, modes and command semantics to imitate")
    p.add_argument("--start-ned", type=float, nargs=3, metavar=("N", "E", "D"),
                   default=(0.0, 0.0, 0.0), help="initial position in local NED [m]")
    p.add_argument("--speed", type=float, default=10.0, help="maximum speed [m/s]")
    p.add_argument("--accel", type=float, default=5.0, help="maximum acceleration [m/s^2]")
    p.add_argument("--airborne", action="store_true",
                   help="start armed and flying in GUIDED (ardupilot) or OFFBOARD (px4), "
                        "with no boot phase")
    p.add_argument("--offboard-timeout", type=float, default=0.5,
                   help="PX4: leave OFFBOARD after this long without setpoints [s]")
    p.add_argument("--boot-s", type=float, default=3.0,
                   help="boot phase: no position and arming refused for this long [s]")
    p.add_argument("--home", default=",".join(str(c) for c in SITL_HOME),
                   help="LAT,LON,ALT (deg, deg, m AMSL) of the local NED origin "
                        "(default: ArduPilot SITL's)")
    p.add_argument("--gcs-sysid", type=int, default=255,
                   help="the only ground-station sysid obeyed (the bridge's source_sysid); "
                        "0 obeys anyone")
    p.add_argument("--signing-key-file", default="",
                   help="MAVLink 2 signing key (32 raw bytes or 64 hex characters): sign "
                        "everything, accept only signed frames")
    p.add_argument("--position-noise-std", type=float, default=0.0, metavar="M",
                   help="std of the reported position's error per NED axis, a slowly "
                        "wandering (Gauss-Markov) one as an EKF's under GNSS noise [m] "
                        "(0: none)")
    p.add_argument("--position-noise-tau", type=float, default=estimate_error.DEFAULT_TAU_S,
                   metavar="S", help="correlation time of that error [s]")
    p.add_argument("--noise-seed", type=int, default=0, metavar="N",
                   help="seed of that error (with the sysid: each vehicle its own)")
    p.add_argument("--wind-mps", type=float, nargs=3, metavar=("N", "E", "D"),
                   default=(0.0, 0.0, 0.0),
                   help="steady wind in local NED [m/s]: off the ground it pushes the "
                        "vehicle, which then holds its position target downwind of it")
    return p


def _stderr(line: str) -> None:
    print(f"{PROG}: {line}", file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    """Run one vehicle until SIGINT / SIGTERM; the exit code (module docstring)."""
    args = build_parser().parse_args(argv)
    try:
        key = None
        if args.signing_key_file:
            key, warning = read_key_file(args.signing_key_file)
            if warning:
                _stderr("warning: " + warning)
        vehicle = SimVehicle(args.sysid, args.listen, args.autopilot, tuple(args.start_ned),
                             args.speed, args.accel, args.airborne, args.offboard_timeout,
                             boot_s=args.boot_s, home=parse_home(args.home),
                             gcs_sysid=args.gcs_sysid, signing_key=key, log=_stderr,
                             position_noise_std_m=args.position_noise_std,
                             position_noise_tau_s=args.position_noise_tau,
                             noise_seed=args.noise_seed, wind_ned=tuple(args.wind_mps))
    except ValueError as exc:
        _stderr(f"error: {exc}")
        return EXIT_BAD_INPUT
    stop = threading.Event()

    def stop_once(*_: object) -> None:
        # Ctrl-C under `ros2 launch` comes twice, the terminal's and launch's own: the next one
        # is ignored, else it may meet the default handler the interpreter puts back as it
        # shuts down, and end the process by the signal instead of EXIT_OK
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, stop_once)
    # The port bound, for `udpin:HOST:0` (what the demo starts it with, then reads here).
    listen = (args.listen if vehicle.port is None else
              f"{args.listen.rsplit(':', 1)[0]}:{vehicle.port}")
    print(f"vehicle sysid {args.sysid} ({args.autopilot}) on {listen}", flush=True)
    try:
        vehicle.run(stop)
    finally:
        vehicle.stop()
    return EXIT_OK if vehicle.failure is None else EXIT_CRASH
