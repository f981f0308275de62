"""`make demo` / `python -m uav_insar_planner.demo`: one whole mission, eight processes.

Starts three `agent` executables and the `planner` as separate processes, as `ros2 run` would,
on a private ROS_DOMAIN_ID with discovery kept on this host; this process watches the topics
like `ros2 topic echo` would. Unless `--no-mavlink`, it also closes the MAVLink loop: three
`uav-insar-vehicle` processes (SITL-style, sysid 2..4, airborne, on free loopback UDP ports)
and the `mavlink_bridge` node wired to them, which flies the planned formation through real
MAVLink bytes; the vehicles' positions come back on /uavK/mavlink/pose. The vehicles fly in
wall-clock time (no time_scale): they gather at their start points, then fly a short pass of
`--mavlink-pass-s` seconds along the track at speed_mps.

Unless `--no-bag`, `uav-insar record` runs beside the nodes from before the agents start to
after they stop, so the whole mission lands in a rosbag2 MCAP bag (`--bag PATH`, default
bags/demo_<UTC time>); its path is printed at the start and the end.

It prints /formation, each UAV's achieved rate per slot (a compact table), the MAVLink
vehicles (a table), and a summary (per UAV: slots and rates; per vehicle: the across-track
error to the planned (x_k, z_k) on the pass, max and final, and the distance flown along the
track); then stops every process with SIGINT (as Ctrl-C would).

With `--kill-uav K --at SLOT` it kills agent K's process (SIGKILL) once the swarm reached
SLOT, waits for the planner's answer (a formation without uavK after `uav_timeout_s`, or the
hold when K is the master) and adds to the summary when it came and what the plan status said.

Exit code 0 when every flown UAV reported every slot and every flown vehicle flew its pass
(with --kill-uav: the planner answered, and every surviving UAV finished); 1 when something
did not happen in time (no plan, a process died, slots missing, no pass); 2 for bad options.
"""
from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from uav_insar_planner.demo.processes import (
    PRINT_LOCK,
    executable,
    free_udp_ports,
    random_domain_id,
    ros_env,
    start_node,
    start_process,
    stop_nodes,
)
from uav_insar_planner.demo.recorder import (
    default_bag_path,
    recorder_ready,
    start_recorder,
    stop_recorder,
)
from uav_insar_planner.report.flown import MavlinkPass, mavlink_table, rate_table, summary
from uav_insar_planner.swarm import UAVS

REPO_CONFIG = Path(__file__).resolve().parents[1] / "config" / "params.yaml"
# MAVLink part: the bridge starts the pass once every vehicle is this close to its start point
# (tighter than the bridge's 1 m default, so the pass shows tracking, not the approach).
CAPTURE_RADIUS_M = 0.2
SETTLE_S = 3.0  # after the pass: the vehicles brake past its end and return; then the final error
MAVLINK_TIMEOUT_S = 30.0  # for the approach and the pass, after the agents are done
FIRST_SYSID = 2  # vehicles sysid 2, 3, 4: the bridge's default target_sysids
# --kill-uav: the agents' default time_scale, slow enough that the swarm flies on for a while
# after uav_timeout_s (5 s: 20 slots at 4x); the planner's answer may take that long and more.
KILL_TIME_SCALE = 4.0
ANSWER_TIMEOUT_S = 60.0


def swarm_slot(w) -> int:
    """The latest slot any agent reported on uavK/offload (-1 before any)."""
    return max((int(o[-1][0]) for o in w.offloads.values() if o), default=-1)


def kill_agent(w, procs: list[subprocess.Popen], k: int, slot: int,
               timeout: float) -> tuple[list[str], bool]:
    """Kill agent k (procs[k]) with SIGKILL once the swarm reached `slot`, then wait for the
    planner's next formation; (summary lines, whether the planner answered)."""
    agent = procs[k]
    if not w.spin_until(lambda: swarm_slot(w) >= slot, timeout, procs):
        return [f"  kill: the swarm never reached slot {slot}"], False
    agent.send_signal(signal.SIGKILL)
    killed, at, seen = time.monotonic(), swarm_slot(w), len(w.formations)
    print(f"demo: killed agent{k} (SIGKILL) at slot {at}", flush=True)
    others = [p for p in procs if p is not agent]
    if not w.spin_until(lambda: len(w.formations) > seen, ANSWER_TIMEOUT_S, others):
        return [f"  kill: agent{k} killed at slot {at}; no new formation came"], False
    after = time.monotonic() - killed
    w.spin_until(lambda: False, 1.0, others)  # the agents' and the bridge's reactions, logged
    w.spin_until(lambda: (s := w.plan_status()) is not None and f"uav{k}" in s.message
                 and "lost" in s.message, 5.0, others)
    status = w.plan_status()
    values = {kv.key: kv.value for kv in status.values} if status else {}
    swarm = [s for m in w.diagnostics for s in m.status if s.name == "planner: swarm"]
    timeout_s = {kv.key: kv.value for kv in swarm[-1].values}.get("uav_timeout_s", "?") \
        if swarm else "?"
    lines = [f"  kill: agent{k} killed (SIGKILL) at slot {at}; new formation {after:.2f} s "
             f"later (uav_timeout_s {timeout_s} s)"]
    if "replan_latency_s" in values:
        lines.append(f"  planner: detection to new formation "
                     f"{float(values['replan_latency_s']) * 1e3:.0f} ms")
    if status is None:
        lines.append("  kill: no plan status came")
    return lines, True


def start_mavlink(ports: Sequence[int], pass_s: float, common: Sequence[str],
                  env: dict[str, str]) -> list[subprocess.Popen]:
    """Three vehicles (sysid 2..4, airborne 20 m up, listening on 127.0.0.1:ports[k]) and the
    bridge sending to them; the vehicles first, so the bridge's first datagrams find them."""
    procs = [start_process([*executable("uav-insar-vehicle"), "--sysid",
                            str(FIRST_SYSID + k), "--listen", f"udpin:127.0.0.1:{port}",
                            "--airborne", "--start-ned", "0", str(3 * k), "-20"],
                           env, f"[vehicle{FIRST_SYSID + k}]")
             for k, port in enumerate(ports)]
    connections = ", ".join(f"'udpout:127.0.0.1:{port}'" for port in ports)
    sysids = ", ".join(str(FIRST_SYSID + k) for k in range(len(ports)))
    procs.append(start_node("mavlink_bridge", [
        *common, "-p", f"connections:=[{connections}]", "-p", f"target_sysids:=[{sysids}]",
        "-p", "velocity_feedforward:=true", "-p", f"capture_radius_m:={CAPTURE_RADIUS_M}",
        "-p", f"track_duration_s:={float(pass_s)}"], env, "[bridge]"))
    return procs


# --fading: the benchmark's link (benchmarks/offloading.py): 4 dB shadowing over 20 m, Rician
# K = 6 dB.
FADING = ("shadowing_std_db:=4.0", "shadowing_corr_m:=20.0", "small_scale_fading:=rician",
          "rician_k_db:=6.0")


def link_args(args: argparse.Namespace) -> list[str]:
    """The agents' -p arguments for --offloading, --fading, --wind and --seed."""
    values = [f"offloading:={args.offloading}", f"fading_seed:={args.seed}"]
    if args.fading:
        values += FADING
    if args.wind:
        values.append("wind_mps:=[" + ", ".join(f"{float(v)!r}" for v in args.wind) + "]")
    return [a for v in values for a in ("-p", v)]


def set_by_the_demo(args: argparse.Namespace) -> dict[str, tuple[str, str]]:
    """The parameters this run passes with -p itself, after the params file and the user's
    -p (so rcl would take the demo's): name -> (the node it sets it on, the option to use)."""
    own = {"uav_id": ("agent", "nothing: agentK flies UAV K"),
           "time_scale": ("agent", "--time-scale"),
           "position_noise_std_m": ("agent", "--noise-std"),
           "offloading": ("agent", "--offloading"), "fading_seed": ("agent", "--seed")}
    if args.fading:
        own.update({text.split(":=")[0]: ("agent", "--fading") for text in FADING})
    if args.wind:
        own["wind_mps"] = ("agent", "--wind")
    if args.uav_timeout is not None:
        own["uav_timeout_s"] = ("planner", "--uav-timeout")
    if not args.no_mavlink:
        wired = "nothing: the demo wires the bridge to its vehicles"
        own.update({"connections": ("mavlink_bridge", wired),
                    "target_sysids": ("mavlink_bridge", wired),
                    "velocity_feedforward": ("mavlink_bridge", "nothing: its pass uses true"),
                    "capture_radius_m": ("mavlink_bridge",
                                         f"nothing: its pass uses {CAPTURE_RADIUS_M:g}"),
                    "track_duration_s": ("mavlink_bridge", "--mavlink-pass-s")})
    return own


def overridden_problems(args: argparse.Namespace, overrides: dict[str, Any]) -> list[str]:
    """One line per value of the params file or -p that the demo's own -p would silently
    override (set_by_the_demo), naming the option to use instead."""
    from uav_insar_planner.params import shown
    from uav_insar_planner.params_file import parse_params_file

    own = set_by_the_demo(args)
    given = [("-p ", name, value) for name, value in overrides.items() if name in own]
    if args.params_file:
        file = parse_params_file(args.params_file)
        where = f"params file {str(args.params_file)[:200]!r}: "
        for name, (node, _) in own.items():
            for fqn in [f"agent{k}" for k in UAVS] if node == "agent" else [node]:
                if name in (values := file.values_for(fqn)):
                    given.append((where, name, values[name]))
                    break
    who = {"agent": "the agents", "planner": "the planner", "mavlink_bridge": "the bridge"}
    return [f"{where}{name}: value {shown(value)} is not allowed in the demo, which sets it "
            f"on {who[own[name][0]]} itself; expected {own[name][1]}"
            for where, name, value in given]


def run(args: argparse.Namespace) -> int:
    from uav_insar_planner.evaluate import rate_tolerance_bps
    from uav_insar_planner.params_file import ParamError, load_params, parse_override

    try:
        overrides = dict(parse_override(text) for text in args.param)
        if args.num_slots:
            overrides["num_slots"] = args.num_slots
        params = load_params(args.params_file, overrides)
        if problems := overridden_problems(args, overrides):
            raise ParamError(problems)
    except ParamError as exc:
        print("\n".join(exc.problems), file=sys.stderr)
        return 2
    domain = args.domain_id if args.domain_id is not None else random_domain_id()
    os.environ.update(ros_env(domain))
    from uav_insar_planner.ros.tools.msg_yaml import message_to_yaml
    from uav_insar_planner.ros.tools.topic_watcher import TopicWatcher

    common = ["--params-file", str(args.params_file)] if args.params_file else []
    common += ["-p", f"num_slots:={params.num_slots}", *(a for text in args.param
                                                         for a in ("-p", text))]
    print(f"demo: ROS_DOMAIN_ID={domain}, {params.num_slots} slots of "
          f"{params.slot_duration_s:g} s at time_scale {args.time_scale:g}, scheme "
          f"{params.scheme}, solver {params.solver}", flush=True)
    mavlink_pass: MavlinkPass | None = None

    def on_vehicle(k: int, msg) -> None:
        if mavlink_pass is not None:
            p = msg.pose.position
            mavlink_pass.update(k, (p.x, p.y, p.z), time.monotonic())

    w = TopicWatcher(None, "demo_watcher", on_mavlink_pose=on_vehicle)
    env = ros_env(domain)
    recorder = None if args.no_bag else start_recorder(args.bag, env)
    if recorder is not None:
        print(f"demo: recording the mission to {args.bag}", flush=True)
    procs = [start_node("agent", [*common, "-p", f"uav_id:={k}", "-p",
                                  f"time_scale:={args.time_scale}", "-p",
                                  f"position_noise_std_m:={args.noise_std}",
                                  *link_args(args), "-r", f"__node:=agent{k}"], env,
                                 f"[agent{k}]")
             for k in range(3)]
    ports: list[int] = []
    try:
        if not w.spin_until(lambda: w.agents_matched() and (
                recorder is None or recorder_ready(w.node)), 20.0, procs):
            print("demo: the agents did not come up (see their log above)", flush=True)
            return 1
        timeout = [] if args.uav_timeout is None else ["-p", f"uav_timeout_s:={args.uav_timeout}"]
        procs.append(start_node("planner", [*common, *timeout], env, "[planner]"))
        if not args.no_mavlink:
            ports = ([args.mavlink_base_port + 10 * k for k in range(3)]
                     if args.mavlink_base_port else free_udp_ports(3))
            print(f"demo: MAVLink vehicles sysid {FIRST_SYSID}..{FIRST_SYSID + 2} on UDP "
                  f"ports {', '.join(map(str, ports))}, pass of {args.mavlink_pass_s:g} s",
                  flush=True)
            procs += start_mavlink(ports, args.mavlink_pass_s, common, env)
        if not w.spin_until(lambda: (w.formations and w.powers) or w.plan_failed(), 40.0,
                            procs) or w.plan_failed():
            print("demo: no plan on /formation (see the planner's log above)", flush=True)
            return 1
        plan_time = time.monotonic()
        formation, n_slots = w.formations[0], w.powers[0].layout.dim[1].size
        mission_s = n_slots * params.slot_duration_s + 60.0  # + transit and run-up
        with PRINT_LOCK:
            print("\n$ ros2 topic echo /formation  (first message)")
            print(message_to_yaml(formation) + "---", flush=True)
        targets = {k: (p.position.x, p.position.y, p.position.z)
                   for k, p in enumerate(formation.poses) if math.isfinite(p.position.x)}
        if not args.no_mavlink:
            mavlink_pass = MavlinkPass(targets, CAPTURE_RADIUS_M)
        killed, kill_lines, answered = set(), [], True
        if args.kill_uav is not None:
            killed = {args.kill_uav}
            kill_lines, answered = kill_agent(w, procs, args.kill_uav, args.at,
                                              mission_s / args.time_scale + 10.0)
        running = [p for k, p in enumerate(procs) if k not in killed]
        finishing = [] if 0 in killed else [k for k in targets if k not in killed]
        last = w.formations[-1]
        # (a UAV whose first slots were flown before the watcher saw it: its last slot counts)
        complete = answered and w.spin_until(
            lambda: all(len(w.rates[k]) >= n_slots or (
                w.offloads[k] and w.offloads[k][-1][0] == n_slots - 1) for k in finishing),
            mission_s / args.time_scale + 10.0, running)
        if finishing:  # the survivors' targets of the re-plan
            targets = {k: ((p.position.x, p.position.y, p.position.z) if k in finishing
                           else targets[k]) for k, p in enumerate(last.poses) if k in targets}
        flew_pass = mavlink_pass is None or 0 in killed or w.spin_until(
            lambda: mavlink_pass.done(time.monotonic(), args.mavlink_pass_s + SETTLE_S),
            MAVLINK_TIMEOUT_S, running)
        tol = rate_tolerance_bps(params.rate_min_bps)
        # /diagnostics is volatile: a short mission can end before its publisher is matched.
        w.spin_until(lambda: w.plan_status() is not None, 5.0, running)
        status = w.plan_status()
        with PRINT_LOCK:
            print("\nachieved rate per slot [Mbit/s], slots first-last ('!' = below R_min)")
            print("\n".join(rate_table(w.rates, list(targets), params.rate_min_bps, tol)))
            if mavlink_pass is not None:
                print("\nMAVLink vehicles (track frame [m]; positions from /uavK/mavlink/pose)")
                print("\n".join(mavlink_table(
                    mavlink_pass, [FIRST_SYSID + k for k in range(3)],
                    [f"udpin:127.0.0.1:{port}" for port in ports])))
            energy = {k: w.offloads[k][-1][2] for k in targets if w.offloads[k]}
            print(summary(status.message if status else None, targets, w.rates, n_slots,
                          params.rate_min_bps, tol, mavlink_pass, plan_time,
                          args.mavlink_pass_s * params.speed, energy, params.e_max_j),
                  flush=True)
            if kill_lines:
                print("\n".join(kill_lines), flush=True)
        if not complete:
            print("demo: the mission did not complete in time", flush=True)
        if not flew_pass:
            print("demo: the MAVLink vehicles did not fly their pass in time", flush=True)
        return 0 if complete and flew_pass else 1
    finally:
        codes = stop_nodes(procs)
        w.destroy()
        what = "planner and agents" if args.no_mavlink else "planner, agents, vehicles, bridge"
        print(f"demo: stopped {what} (exit codes {codes})", flush=True)
        if recorder is not None:
            code, line = stop_recorder(recorder)
            print(f"demo: {line} (recorder exit code {code}); plot it with `uav-insar "
                  f"report {args.bag}`", flush=True)


def main(argv: list[str] | None = None) -> int:
    """Parse the options and fly the demo; returns the exit code (see the module docstring)."""
    parser = argparse.ArgumentParser(prog="python -m uav_insar_planner.demo",
                                     description="Fly one mission: planner + three agents, "
                                                 "and the MAVLink bridge + three vehicles.")
    parser.add_argument("--params-file", type=Path,
                        default=REPO_CONFIG if REPO_CONFIG.exists() else None,
                        help="ROS 2 params file for every node (default: config/params.yaml)")
    parser.add_argument("--num-slots", type=int, default=0,
                        help="override num_slots (default: the params file's)")
    parser.add_argument("--time-scale", type=float, default=None,
                        help="agents' mission seconds per wall second (default 20, 4 with "
                             "--kill-uav)")
    parser.add_argument("--noise-std", type=float, default=0.0,
                        help="agents' position disturbance std per axis [m] (default 0)")
    parser.add_argument("--offloading", choices=("open", "closed"), default="open",
                        help="agents' power per slot: the plan's, or closed loop (default open)")
    parser.add_argument("--fading", action="store_true",
                        help="simulated link: 4 dB shadowing over 20 m and Rician K 6 dB")
    parser.add_argument("--wind", type=float, nargs=3, metavar=("VX", "VY", "VZ"),
                        help="steady wind in the track frame [m/s] (each in [-50, 50])")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the fading and the gusts (default 0)")
    parser.add_argument("-p", "--param", action="append", default=[], metavar="NAME:=VALUE",
                        help="a parameter for every node, e.g. -p solver:=paper-ao")
    parser.add_argument("--domain-id", type=int, default=None,
                        help="ROS_DOMAIN_ID to use (default: a random one in 1..101)")
    parser.add_argument("--no-mavlink", action="store_true",
                        help="skip the MAVLink part (bridge and vehicles)")
    parser.add_argument("--mavlink-pass-s", type=float, default=5.0,
                        help="how long the vehicles fly along the track, wall clock (default 5)")
    parser.add_argument("--mavlink-base-port", type=int, default=0,
                        help="vehicles listen on UDP PORT, PORT+10, PORT+20 (default: free "
                             "ports chosen by the OS)")
    parser.add_argument("--kill-uav", type=int, choices=(0, 1, 2), default=None, metavar="K",
                        help="kill agent K's process (SIGKILL) when the swarm reaches --at SLOT "
                             "and show the planner's re-plan")
    parser.add_argument("--at", type=int, default=10, metavar="SLOT",
                        help="the slot for --kill-uav (default 10)")
    parser.add_argument("--uav-timeout", type=float, default=None, metavar="S",
                        help="the planner's uav_timeout_s (default: its own, 5 s)")
    parser.add_argument("--bag", type=Path, default=None, metavar="PATH",
                        help="record the mission into this new rosbag2 folder (default: "
                             "bags/demo_<UTC time>)")
    parser.add_argument("--no-bag", action="store_true", help="do not record the mission")
    args = parser.parse_args(argv)
    args.bag = args.bag or default_bag_path()
    if not args.no_bag and args.bag.exists():
        parser.error(f"--bag: {str(args.bag)[:200]!r} exists; expected a new folder")
    if args.uav_timeout is not None and not 0.1 <= args.uav_timeout <= 3600.0:
        parser.error("--uav-timeout must be in [0.1, 3600] s")
    if args.time_scale is None:
        args.time_scale = 20.0 if args.kill_uav is None else KILL_TIME_SCALE
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
    if not args.mavlink_pass_s > 0 or not 0 <= args.mavlink_base_port <= 65515:
        parser.error("--mavlink-pass-s must be > 0 and --mavlink-base-port in 0..65515")
    return run(args)
