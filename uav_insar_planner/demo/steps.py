"""The demo's mission, step by step: each method of `Mission` is one step of `mission.run`,
called in order; the processes it started and what its watcher saw are its state. What the
demo sets on the nodes itself (`set_by_the_demo`) a params file or -p may not set too
(`overridden_problems`): rcl would let the demo's value win, silently."""
from __future__ import annotations

import argparse
import math
import subprocess
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from uav_insar_planner.demo.kill import kill_agent
from uav_insar_planner.demo.processes import (
    PRINT_LOCK,
    STOP_TIMEOUT_S,
    ros_env,
    start_node,
    start_vehicle,
    stop_nodes,
)
from uav_insar_planner.demo.recorder import recorder_ready, start_recorder, stop_recorder
from uav_insar_planner.param_specs.nodes import FIRST_SYSID, PORT_STEP, vehicle_start_ned
from uav_insar_planner.report.flown import MavlinkPass, mavlink_table, rate_table, summary
from uav_insar_planner.swarm import MASTER, MAX_UAVS, agent_name, uav_name, uavs
from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_planner.track.passes import run_in_m

if TYPE_CHECKING:
    from uav_insar_planner.params import Params

# MAVLink part: the bridge starts the pass once every vehicle is this close to its start point
# (tighter than the bridge's 1 m default, so the pass shows tracking, not the approach).
CAPTURE_RADIUS_M = 0.2
SETTLE_S = 3.0  # after the pass: the vehicles brake past its end and return; then the final error
MAVLINK_TIMEOUT_S = 30.0  # for the approach (and the pass's end, after the agents are done)
AGENTS_UP_S = 20.0  # until the watcher (and the recorder) sees every agent
PLAN_S = 40.0  # until the first plan, after the planner started
TRANSIT_S = 60.0  # mission seconds beyond the slots: transit and run-up
STATUS_S = 5.0  # for the plan status on /diagnostics, after the mission
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


def bridge_args(ports: Sequence[int], per_uav_stacks: bool) -> list[list[str]]:
    """The ROS arguments of the bridge(s) wired to the vehicles on `ports`: one bridge for
    the swarm, or (`per_uav_stacks`) one per UAV in /uavK flying UAV K's vehicle only."""
    def wired(uavs: Sequence[int]) -> list[str]:
        connections = ", ".join(f"'udpout:127.0.0.1:{ports[k]}'" for k in uavs)
        sysids = ", ".join(str(FIRST_SYSID + k) for k in uavs)
        return ["-p", f"connections:=[{connections}]", "-p", f"target_sysids:=[{sysids}]"]

    if not per_uav_stacks:
        return [wired(range(len(ports)))]
    return [["-r", f"__ns:=/{uav_name(k)}", "-p", f"uav_id:={k}", *wired([k])]
            for k in range(len(ports))]


def start_mavlink(ports: Sequence[int], pass_s: float, common: Sequence[str],
                  env: dict[str, str], per_uav_stacks: bool = False
                  ) -> tuple[list[subprocess.Popen], list[int] | None]:
    """One vehicle per port (sysid FIRST_SYSID + k, airborne above agent k's home, listening
    on 127.0.0.1:ports[k], 0: a port the system chooses) and the bridge(s) sending to them
    (`bridge_args`), the pass `pass_s` long; the vehicles first, so the bridges' first
    datagrams find them. Returns the processes and the vehicles' ports (None, and no bridge:
    a vehicle did not start)."""
    procs, bound = [], []
    for k, port in enumerate(ports):
        proc, found = start_vehicle(
            ["--sysid", str(FIRST_SYSID + k), "--airborne", "--start-ned",
             *(str(v) for v in vehicle_start_ned(k))],
            "127.0.0.1", port, env, f"[vehicle{FIRST_SYSID + k}]")
        procs.append(proc)
        bound.append(found)
    if None in bound:
        return procs, None
    for k, wiring in enumerate(bridge_args(bound, per_uav_stacks)):
        procs.append(start_node("mavlink_bridge", [
            *common, *wiring, "-p", "velocity_feedforward:=true",
            "-p", f"capture_radius_m:={CAPTURE_RADIUS_M}",
            "-p", f"track_duration_s:={float(pass_s)}"], env,
            f"[{uav_name(k)}/bridge]" if per_uav_stacks else "[bridge]"))
    return procs, bound


def pass_duration_s(params: Params) -> float:
    """The bridge's pass: the slots and one more, so every UAV crosses the line after its
    last slot (ObservedMission's end)."""
    return (params.num_slots + 1) * params.slot_duration_s


def node_names(node: str, args: argparse.Namespace) -> list[str]:
    """The full names the demo gives `node`'s processes (params-file sections match these),
    for the --uavs flown (without it, every UAV a swarm may have: its num_uavs is not known
    before the params file is read)."""
    stacks = getattr(args, "per_uav_stacks", False)
    swarm = uavs(getattr(args, "uavs", None) or MAX_UAVS)
    if node == "agent":
        return [f"/{uav_name(k)}/agent" if stacks else agent_name(k) for k in swarm]
    if node == "mavlink_bridge" and stacks:
        return [f"/{uav_name(k)}/mavlink_bridge" for k in swarm]
    return [node]


def set_by_the_demo(args: argparse.Namespace) -> dict[str, tuple[tuple[str, ...], str]]:
    """The parameters this run passes with -p itself, after the params file and the user's
    -p (so rcl would take the demo's): name -> (the nodes it sets it on, the option to use)."""
    agent, bridge = ("agent",), ("mavlink_bridge",)
    own = {"uav_id": (agent, "nothing: agentK flies UAV K"),
           "time_scale": (agent, "--time-scale"),
           "position_noise_std_m": (agent, "--noise-std"),
           "offloading": (agent, "--offloading"), "fading_seed": (agent, "--seed")}
    if args.fading:
        own.update({text.split(":=")[0]: (agent, "--fading") for text in FADING})
    if args.wind:
        own["wind_mps"] = (agent, "--wind")
    if args.uav_timeout is not None:
        own["uav_timeout_s"] = (("planner",), "--uav-timeout")
    if not args.no_mavlink:
        own["position_source"] = (agent, "--no-mavlink for agent, else autopilot")
        wired = "nothing: the demo wires the bridge to its vehicles"
        radius = f"nothing: its pass uses {CAPTURE_RADIUS_M:g}"
        own.update({"connections": (bridge, wired), "target_sysids": (bridge, wired),
                    "velocity_feedforward": (bridge, "nothing: its pass uses true"),
                    "capture_radius_m": (("planner",) + bridge, radius),
                    "track_duration_s": (bridge, "--num-slots (the pass is one slot longer "
                                         "than the slots)")})
        if args.per_uav_stacks:
            own["uav_id"] = (agent + bridge, "nothing: /uavK's stack flies UAV K")
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
        for name, (nodes, _) in own.items():
            for fqn in (fqn for node in nodes for fqn in node_names(node, args)):
                if name in (values := file.values_for(fqn)):
                    given.append((where, name, values[name]))
                    break
    who = {"agent": "the agents", "planner": "the planner", "mavlink_bridge": "the bridges"}
    return [f"{where}{name}: value {shown(value)} is not allowed in the demo, which sets it "
            f"on {' and '.join(who[node] for node in own[name][0])} itself; expected "
            f"{own[name][1]}" for where, name, value in given]


class Mission:
    """One run of the demo. `procs` holds agent k at index k, then the planner, the vehicles
    and the bridge; `targets` each flown UAV's planned (x_k, y_start, z_k)."""

    def __init__(self, args: argparse.Namespace, params: Params, domain: int) -> None:
        from uav_insar_planner.ros.tools.topic_watcher import TopicWatcher

        self.args, self.params, self.env = args, params, ros_env(domain)
        self.common = ["--params-file", str(args.params_file)] if args.params_file else []
        # the swarm's size and R_min,k as the demo validated them (--uavs fits the R_min list)
        rate_min = ", ".join(repr(float(r)) for r in params.raw["rate_min_mbps"])
        self.common += ["-p", f"num_slots:={params.num_slots}",
                        *(a for text in args.param for a in ("-p", text)),
                        "-p", f"num_uavs:={params.num_uavs}",
                        "-p", f"rate_min_mbps:=[{rate_min}]"]
        self.swarm = uavs(params.num_uavs)
        print(f"demo: ROS_DOMAIN_ID={domain}, {params.num_uavs} UAVs, {params.num_slots} slots of "
              f"{params.slot_duration_s:g} s at time_scale {args.time_scale:g}, scheme "
              f"{params.scheme}, solver {params.solver}", flush=True)
        self.procs: list[subprocess.Popen] = []
        self.running: list[subprocess.Popen] = []  # procs less the killed agent
        self.recorder: subprocess.Popen | None = None
        self.ports: list[int] = []
        self.mavlink_pass: MavlinkPass | None = None
        self.targets: dict[int, tuple[float, float, float]] = {}
        self.n_slots, self.plan_time, self.wall_timeout_s = 0, 0.0, 0.0
        self.pass_s = pass_duration_s(params)
        self.watcher = TopicWatcher(None, "demo_watcher", on_mavlink_pose=self._on_vehicle,
                                    num_uavs=params.num_uavs)

    def _on_vehicle(self, k: int, msg: Any) -> None:
        if self.mavlink_pass is not None:
            p = msg.pose.position
            self.mavlink_pass.update(k, (p.x, p.y, p.z), time.monotonic())

    def start_agents(self) -> bool:
        """Start the recorder (unless --no-bag), then one agent per UAV; True once the watcher
        sees every agent and the recorder subscribes to them (no slot's rate is missed)."""
        args, w = self.args, self.watcher
        self.recorder = None if args.no_bag else start_recorder(args.bag, self.env)
        if self.recorder is not None:
            print(f"demo: recording the mission to {args.bag}", flush=True)
        source = "agent" if args.no_mavlink else "autopilot"
        for k in self.swarm:
            self.procs.append(start_node(
                "agent", [*self.common, "-p", f"uav_id:={k}", "-p",
                          f"time_scale:={args.time_scale}", "-p",
                          f"position_noise_std_m:={args.noise_std}", *link_args(args),
                          *([] if args.no_mavlink else ["-p", f"position_source:={source}"]),
                          *self._agent_name_args(k)], self.env, f"[{agent_name(k)}]"))
        if not w.spin_until(lambda: w.agents_matched() and (
                self.recorder is None or recorder_ready(w.node, self.swarm)), AGENTS_UP_S,
                self.procs):
            print("demo: the agents did not come up (see their log above)", flush=True)
            return False
        return True

    def _agent_name_args(self, k: int) -> list[str]:
        """Agent k as /uavK/agent (its UAV's stack) or as agentK beside the others."""
        if self.args.per_uav_stacks:
            return ["-r", f"__ns:=/{uav_name(k)}"]
        return ["-r", f"__node:={agent_name(k)}"]

    def start_planner_and_mavlink(self) -> bool:
        """Start the planner and, unless --no-mavlink, one vehicle per UAV and the bridge;
        False when a vehicle did not start."""
        args = self.args
        own = [] if args.uav_timeout is None else ["-p", f"uav_timeout_s:={args.uav_timeout}"]
        if not args.no_mavlink:  # the planner starts the pass once every UAV is this close
            own += ["-p", f"capture_radius_m:={CAPTURE_RADIUS_M}"]
        self.procs.append(start_node("planner", [*self.common, *own], self.env, "[planner]"))
        if args.no_mavlink:
            return True
        asked = ([args.mavlink_base_port + PORT_STEP * k for k in self.swarm]
                 if args.mavlink_base_port else [0] * len(self.swarm))
        procs, ports = start_mavlink(asked, self.pass_s, self.common, self.env,
                                     args.per_uav_stacks)
        self.procs += procs
        if ports is None:
            print("demo: a MAVLink vehicle did not start (see its lines above)", flush=True)
            return False
        self.ports = ports
        flown_by = ("one bridge per UAV (/uavK/mavlink_bridge, uav_id K; the planner starts "
                    "every pass at one instant)" if args.per_uav_stacks else "the bridge")
        print(f"demo: MAVLink vehicles sysid {FIRST_SYSID}..{FIRST_SYSID + len(self.ports) - 1} on "
              f"UDP ports {', '.join(map(str, self.ports))}, flown by {flown_by} for the whole "
              f"mission (a pass of {self.pass_s:g} s); the agents take their positions from "
              "them (position_source autopilot)", flush=True)
        return True

    def wait_for_plan(self) -> bool:
        """Wait for the first plan and echo its /formation; False when none came (or the
        planner reported it failed)."""
        from uav_insar_planner.ros.tools.msg_yaml import message_to_yaml

        w = self.watcher
        if not w.spin_until(lambda: (w.formations and w.powers) or w.plan_failed(), PLAN_S,
                            self.procs) or w.plan_failed():
            print("demo: no plan on /formation (see the planner's log above)", flush=True)
            return False
        self.plan_time = time.monotonic()
        formation, self.n_slots = w.formations[0], w.powers[0].layout.dim[1].size
        slots_s = self.n_slots * self.params.slot_duration_s
        self.wall_timeout_s = ((slots_s + TRANSIT_S) / self.args.time_scale + 10.0
                               if self.args.no_mavlink else slots_s + MAVLINK_TIMEOUT_S + 10.0)
        with PRINT_LOCK:
            print("\n$ ros2 topic echo /formation  (first message)")
            print(message_to_yaml(formation) + "---", flush=True)
        self.targets = {k: (p.position.x, p.position.y, p.position.z)
                        for k, p in enumerate(formation.poses) if math.isfinite(p.position.x)}
        if not self.args.no_mavlink:
            self.mavlink_pass = MavlinkPass(self.targets, CAPTURE_RADIUS_M,
                                            run_in_m(self.params.speed))
        return True

    def fly(self) -> tuple[bool, bool, list[str]]:
        """Follow the mission to its end, first killing agent --kill-uav at --at if asked:
        (every finishing UAV reported every slot, the vehicles flew their pass, the kill's
        summary lines)."""
        w, args, n = self.watcher, self.args, self.n_slots
        killed, kill_lines, answered = set(), [], True
        if args.kill_uav is not None:
            killed = {args.kill_uav}
            kill_lines, answered = kill_agent(w, self.procs, args.kill_uav, args.at,
                                              self.wall_timeout_s)
        self.running = [p for k, p in enumerate(self.procs) if k not in killed]
        finishing = [] if MASTER in killed else [k for k in self.targets if k not in killed]
        last = w.formations[-1]
        def last_offload(k: int) -> bool:
            return bool(w.offloads[k]) and w.offloads[k][-1][0] == n - 1

        # (a UAV whose first slots were flown before the watcher saw it: its last slot counts)
        complete = answered and w.spin_until(
            lambda: all(len(w.rates[k]) >= n or last_offload(k) for k in finishing),
            self.wall_timeout_s, self.running)
        # the last slot's energy, which may come just after its rate (ten UAVs: often)
        w.spin_until(lambda: all(last_offload(k) for k in finishing), STATUS_S, self.running)
        if finishing:  # the survivors' targets of the re-plan
            self.targets = {k: ((p.position.x, p.position.y, p.position.z) if k in finishing
                                else self.targets[k])
                            for k, p in enumerate(last.poses) if k in self.targets}
        flew_pass = self.mavlink_pass is None or MASTER in killed or w.spin_until(
            lambda: self.mavlink_pass.done(time.monotonic(), self.pass_stop_s() + SETTLE_S),
            MAVLINK_TIMEOUT_S, self.running)
        return complete, flew_pass, kill_lines

    def pass_stop_s(self) -> float:
        """From the pass start until the bridges' targets stop: the run-in from the hover, the
        pass and its braking, on the pass's clock."""
        v = self.params.speed
        return PassClock(0.0, v, -run_in_m(v), self.pass_s).time_at(v * self.pass_s)

    def print_tables(self, kill_lines: list[str]) -> None:
        """The achieved rates, the MAVLink vehicles and the summary, as one block."""
        from uav_insar_planner.evaluate import rate_tolerance_bps

        w, params = self.watcher, self.params
        tol = rate_tolerance_bps(params.rate_min_bps)
        # /diagnostics is volatile: a short mission can end before its publisher is matched.
        w.spin_until(lambda: w.plan_status() is not None, STATUS_S, self.running)
        status = w.plan_status()
        with PRINT_LOCK:
            print("\nachieved rate per slot [Mbit/s], slots first-last ('!' = below R_min)")
            print("\n".join(rate_table(w.rates, list(self.targets), params.rate_min_bps, tol)))
            if self.mavlink_pass is not None:
                print("\nMAVLink vehicles (track frame [m]; positions from /uavK/mavlink/pose)")
                print("\n".join(mavlink_table(
                    self.mavlink_pass, [FIRST_SYSID + k for k in self.swarm],
                    [f"udpin:127.0.0.1:{port}" for port in self.ports])))
            energy = {k: w.offloads[k][-1][2] for k in self.targets if w.offloads[k]}
            print(summary(status.message if status else None, self.targets, w.rates,
                          self.n_slots, params.rate_min_bps, tol, self.mavlink_pass,
                          self.plan_time, self.pass_s * params.speed, energy,
                          params.e_max_j), flush=True)
            if kill_lines:
                print("\n".join(kill_lines), flush=True)

    def _proc_names(self) -> list[str]:
        """What each of `procs` is, in their order."""
        names = [agent_name(k) for k in self.swarm] + ["planner"]
        names += [f"vehicle{FIRST_SYSID + k}" for k in range(len(self.ports))]
        if self.ports:
            names += ([f"{uav_name(k)}/bridge" for k in range(len(self.ports))]
                      if self.args.per_uav_stacks else ["bridge"])
        return names

    def stop(self) -> None:
        """Stop every process (SIGINT first, as Ctrl-C would), the watcher, then the
        recorder, and say so."""
        codes = stop_nodes(self.procs)
        self.watcher.destroy()
        what = ("agents and planner" if self.args.no_mavlink
                else "agents, planner, vehicles, bridges" if self.args.per_uav_stacks
                else "agents, planner, vehicles, bridge")
        print(f"demo: stopped {what} (exit codes {codes})", flush=True)
        for name, code in zip(self._proc_names(), codes, strict=False):  # an early stop
            if code < 0:
                print(f"demo: {name} did not stop within {2 * STOP_TIMEOUT_S:g} s of SIGINT "
                      f"and SIGTERM; killed (exit code {code}, its stacks above)", flush=True)
        if self.recorder is not None:
            code, line = stop_recorder(self.recorder)
            print(f"demo: {line} (recorder exit code {code}); plot it with `uav-insar "
                  f"report {self.args.bag}`", flush=True)
