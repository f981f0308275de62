"""`make demo` / `python -m uav_insar_planner.demo`: one whole mission, every node a process.

Starts one `agent` executable per UAV (`--uavs N`, 2..10, num_uavs; default the params file's,
Table I's 3) and the `planner` as separate processes, as `ros2 run` would, on a private
ROS_DOMAIN_ID with discovery kept on this host; this process watches the topics like `ros2
topic echo` would. Unless `--no-mavlink`, the agents ride on MAVLink vehicles: one
`uav-insar-vehicle` process per UAV (SITL-style, sysid 2, 3, ..., airborne behind the track
start, on free loopback UDP ports) and the `mavlink_bridge` node wired to them fly the planned
formation through real MAVLink bytes; the vehicles' positions come back on /uavK/mavlink/pose,
and the agents (`position_source:=autopilot`) run their slots on them and republish them as
/uavK/pose, so rates, offload, bag and report are the vehicles'. The vehicles fly in wall-clock
time (no time_scale): they gather at their start points, then fly the pass, num_slots + 1 slots
long (20 slots unless --num-slots), along the track at speed_mps. With `--per-uav-stacks` each
UAV gets a stack of its own, as on its computer: a bridge /uavK/mavlink_bridge (uav_id K) for
its vehicle and the agent /uavK/agent; the planner then starts every pass at one wall-clock
instant (formation/start). With `--no-mavlink` the agents fly themselves on the mission clock.

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
did not happen in time (no plan, a process died, slots missing, no pass); 2 for bad options
or a node parameter a node would refuse (`node_checks`), before any process starts
(`exit_codes`).

The options are `options`; the steps, in the order `run` calls them, `steps.Mission`.
"""
from __future__ import annotations

import argparse
import os
import sys

from uav_insar_planner.demo.node_checks import node_problems
from uav_insar_planner.demo.options import fit_swarm, parse_options
from uav_insar_planner.demo.processes import random_domain_id, ros_env
from uav_insar_planner.demo.steps import Mission, overridden_problems
from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_CRASH, EXIT_OK


def run(args: argparse.Namespace) -> int:
    """Fly the demo with checked options (`options.parse_options`); returns the exit code."""
    from uav_insar_planner.params_file import ParamError, load_params, parse_override

    try:
        overrides = dict(parse_override(text) for text in args.param)
        if args.num_slots is not None:
            overrides["num_slots"] = args.num_slots
        if problems := fit_swarm(args, overrides):
            raise ParamError(problems)
        params = load_params(args.params_file, overrides)
        if problems := overridden_problems(args, overrides):
            raise ParamError(problems)
        if problems := node_problems(args, overrides, params):
            raise ParamError(problems)
    except ParamError as exc:
        print("\n".join(exc.problems), file=sys.stderr)
        return EXIT_BAD_INPUT
    domain = args.domain_id if args.domain_id is not None else random_domain_id()
    os.environ.update(ros_env(domain))
    mission = Mission(args, params, domain)
    try:
        if not mission.start_agents():
            return EXIT_CRASH
        if not mission.start_planner_and_mavlink() or not mission.wait_for_plan():
            return EXIT_CRASH
        complete, flew_pass, kill_lines = mission.fly()
        mission.print_tables(kill_lines)
        if not complete:
            print("demo: the mission did not complete in time", flush=True)
        if not flew_pass:
            print("demo: the MAVLink vehicles did not fly their pass in time", flush=True)
        return EXIT_OK if complete and flew_pass else EXIT_CRASH
    finally:
        mission.stop()


def main(argv: list[str] | None = None) -> int:
    """Parse the options and fly the demo; returns the exit code (see the module docstring)."""
    return run(parse_options(argv))
