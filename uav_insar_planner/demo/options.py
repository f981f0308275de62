"""The demo's command line: its options and their checks, every error one line and exit 2
before any process starts (no ROS import)."""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from uav_insar_planner.cli.parser import OneLineParser
from uav_insar_planner.demo.recorder import default_bag_path
from uav_insar_planner.param_specs.nodes import PORT_STEP
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, MAX_UAVS, MIN_UAVS, fit_to_swarm

REPO_CONFIG = Path(__file__).resolve().parents[1] / "config" / "params.yaml"
# --kill-uav: the agents' default time_scale, slow enough that the swarm flies on for a while
# after uav_timeout_s (5 s: 20 slots at 4x); the planner's answer may take that long and more.
KILL_TIME_SCALE = 4.0
DEFAULT_TIME_SCALE = 20.0
# The MAVLink path flies the whole mission in wall-clock time on the vehicles (1 slot a
# second at Table I's delta_t): its default num_slots, unless --num-slots says otherwise.
MAVLINK_NUM_SLOTS = 20
# --mavlink-base-port: vehicle k listens on PORT + PORT_STEP * k, the last one within 65535.
MAX_PORT = 65535


def build_parser() -> OneLineParser:
    """Every option of `python -m uav_insar_planner.demo` (docs/demo.md)."""
    parser = OneLineParser(prog="python -m uav_insar_planner.demo",
                           description="Fly one mission: the planner and one agent per UAV, "
                                       "and the MAVLink bridge and one vehicle per UAV.")
    add = parser.add_argument
    add("--params-file", type=Path, default=REPO_CONFIG if REPO_CONFIG.exists() else None,
        help="ROS 2 params file for every node (default: config/params.yaml)")
    add("--uavs", type=int, default=None, metavar="N",
        help=f"fly a swarm of N UAVs, {MIN_UAVS}..{MAX_UAVS} (num_uavs; default: the params "
             f"file's, Table I's {DEFAULT_NUM_UAVS}); R_min,k not given for N UAVs: the params "
             "file's first N, its last repeated")
    add("--num-slots", type=int, default=None, metavar="N",
        help=f"override num_slots, 1..100000 (default: {MAVLINK_NUM_SLOTS}; with --no-mavlink "
             "the params file's)")
    add("--time-scale", type=float, default=None,
        help="self-flown agents' mission seconds per wall second (default 20, 4 with "
             "--kill-uav); --no-mavlink only: the vehicles fly in wall-clock time")
    add("--noise-std", type=float, default=0.0,
        help="self-flown agents' position disturbance std per axis [m] (default 0); "
             "--no-mavlink only")
    add("--offloading", choices=("open", "closed"), default="open",
        help="agents' power per slot: the plan's, or closed loop (default open)")
    add("--fading", action="store_true",
        help="simulated link: 4 dB shadowing over 20 m and Rician K 6 dB")
    add("--wind", type=float, nargs=3, metavar=("VX", "VY", "VZ"),
        help="steady wind on the self-flown agents in the track frame [m/s] (each in "
             "[-50, 50]); --no-mavlink only")
    add("--seed", type=int, default=0, help="seed of the fading and the gusts (default 0)")
    add("-p", "--param", action="append", default=[], metavar="NAME:=VALUE",
        help="a parameter for every node, e.g. -p solver:=paper-ao")
    add("--domain-id", type=int, default=None,
        help="ROS_DOMAIN_ID to use (default: a random one in 1..101)")
    add("--no-mavlink", action="store_true",
        help="no bridge and vehicles: the agents fly themselves (position_source agent)")
    add("--per-uav-stacks", action="store_true",
        help="one stack per UAV, as on each UAV's computer: bridge /uavK/mavlink_bridge "
             "(uav_id K) flying its own vehicle and agent /uavK/agent; the planner starts "
             "every pass at one wall-clock instant (formation/start)")
    add("--mavlink-base-port", type=int, default=0,
        help=f"vehicle K listens on UDP PORT + {PORT_STEP} K (default: free ports chosen by "
             "the OS)")
    add("--kill-uav", type=int, default=None, metavar="K",
        help="kill agent K's process (SIGKILL) when the swarm reaches --at SLOT and show the "
             "planner's re-plan")
    add("--at", type=int, default=10, metavar="SLOT", help="the slot for --kill-uav (default 10)")
    add("--uav-timeout", type=float, default=None, metavar="S",
        help="the planner's uav_timeout_s (default: its own, 5 s)")
    add("--bag", type=Path, default=None, metavar="PATH",
        help="record the mission into this new rosbag2 folder (default: bags/demo_<UTC time>)")
    add("--no-bag", action="store_true", help="do not record the mission")
    return parser


def parse_options(argv: list[str] | None = None) -> argparse.Namespace:
    """The options, checked, with the defaults that depend on others filled in (`--bag`,
    `--time-scale`); a bad one exits 2 with one line naming it."""
    parser = build_parser()
    args = parser.parse_args(argv)
    args.bag = args.bag or default_bag_path()
    if not args.no_bag and args.bag.exists():
        parser.error(f"--bag: {str(args.bag)[:200]!r} exists; expected a new folder")
    if args.uav_timeout is not None and not 0.1 <= args.uav_timeout <= 3600.0:
        parser.error("--uav-timeout must be in [0.1, 3600] s")
    if args.per_uav_stacks and args.no_mavlink:
        parser.error("--per-uav-stacks: a stack per UAV is its bridge, vehicle and agent; "
                     "expected it without --no-mavlink")
    if not args.no_mavlink:
        for given, option in ((args.time_scale is not None, "--time-scale"),
                              (args.noise_std != 0.0, "--noise-std"),
                              (args.wind is not None, "--wind")):
            if given:
                parser.error(f"{option}: applies to self-flown agents only; the MAVLink path "
                             "flies the vehicles in wall-clock time; expected --no-mavlink "
                             "with it")
        args.num_slots = MAVLINK_NUM_SLOTS if args.num_slots is None else args.num_slots
    if args.time_scale is None:
        args.time_scale = DEFAULT_TIME_SCALE if args.kill_uav is None else KILL_TIME_SCALE
    if args.at < 0:
        parser.error("--at must be >= 0")
    if args.time_scale <= 0 or args.noise_std < 0:
        parser.error("--time-scale must be > 0 and --noise-std >= 0")
    if args.wind and not all(-50.0 <= v <= 50.0 for v in args.wind):
        parser.error("--wind components must be finite and in [-50, 50] m/s")
    if not 0 <= args.seed <= 2**31 - 1:
        parser.error("--seed must be in 0..2147483647")
    if args.domain_id is not None and not 0 <= args.domain_id <= 232:
        parser.error("--domain-id must be in 0..232 (Fast DDS's range)")
    if args.uavs is not None and not MIN_UAVS <= args.uavs <= MAX_UAVS:
        parser.error(f"--uavs: value {args.uavs} is not allowed; expected {MIN_UAVS}..{MAX_UAVS}")
    # (checked again against the scenario's num_uavs when --uavs is not given: fit_swarm)
    most = args.uavs or MAX_UAVS
    if args.kill_uav is not None and not 0 <= args.kill_uav < most:
        parser.error(f"--kill-uav: value {args.kill_uav} is not allowed; expected a UAV "
                     f"0..{most - 1}")
    max_base_port = MAX_PORT - PORT_STEP * (most - 1)
    if not 0 <= args.mavlink_base_port <= max_base_port:
        parser.error(f"--mavlink-base-port must be in 0..{max_base_port}")
    return args


def fit_swarm(args: argparse.Namespace, overrides: dict[str, Any]) -> list[str]:
    """Put --uavs N into `overrides` (num_uavs) and, unless -p gives rate_min_mbps, R_min,k
    for N UAVs: the params file's, fitted by swarm.fit_to_swarm. Returns the problems (one
    line each) of a --kill-uav beyond the swarm flown."""
    from uav_insar_planner.param_specs.science import SPEC_BY_NAME
    from uav_insar_planner.params_file import read_params_file

    file = read_params_file(args.params_file, "planner") if args.params_file else {}
    if args.uavs is not None:
        overrides["num_uavs"] = args.uavs
        if "rate_min_mbps" not in overrides:
            given = list(file.get("rate_min_mbps", SPEC_BY_NAME["rate_min_mbps"].default))
            if len(given) != args.uavs and given:
                overrides["rate_min_mbps"] = fit_to_swarm(given, args.uavs)
    n = overrides.get("num_uavs", file.get("num_uavs", DEFAULT_NUM_UAVS))
    if args.kill_uav is not None and isinstance(n, int) and args.kill_uav >= n:
        return [f"--kill-uav: value {args.kill_uav} is not allowed; expected a UAV 0..{n - 1} "
                f"of the {n} flown (num_uavs)"]
    return []
