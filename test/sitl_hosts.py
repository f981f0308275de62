"""Three ArduCopter SITL copters (../shared/sitl/) on four hosts, in wind, taking off beside
the track start: the mission test_sitl_across_hosts.py asserts. Not a test file.

Hosts: Linux network namespaces on the lossy user-space switch of netlab_swarm.py
(uav_insar_sim/netlab, RADIO each way), DDS between them, MAVLink only inside each UAV:
- ground: the planner and `uav-insar record` (the bag is what reached the ground);
- uavK: `arducopter -I0` (a working directory of its own, MAVLink on the namespace's own
  tcp:127.0.0.1:5760, wind and GNSS noise from a parm file given to --defaults after
  ArduPilot's copter.parm), simstate_recorder.py on its SERIAL1 (tcp:127.0.0.1:5762) writing
  the physics truth, `mavlink_bridge` (uav_id K, arm_and_takeoff, that one connection) and the
  agent (position_source autopilot), both in the namespace /uavK.

Every copter starts at sitl_autopilot.HOME, which is the track origin (origin_ned_m 0, bearing
0: y north, x east). The formation points (x_k, 0, z_k) are up and to the side of it, so each
copter climbs and moves sideways onto the start line: none reaches it from behind.

`fly` runs it and returns what was recorded; `figures` turns that into the measured figures:
per UAV when its slot 0 was sent against the planner's pass start, its rates against R_min,
and on the pass (t >= the pass start, y between the first and the one-past-last slot line)
its autopilot's (uavK/mavlink/pose in the bag) and the simulator's true (SIMSTATE) across-track
and height errors; and sigma_h of the plan, of the autopilot's and of the true geometry (the
mean (x, z) of each UAV on the pass, evaluated with the plan's power).
"""
from __future__ import annotations

import math
import re
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sitl_autopilot as sitl
import sitl_px4 as px4
import yaml
from netlab_swarm import (
    FAST_DDS_HEARTBEAT_S,
    RADIO,
    Output,
    base_env,
    stop_recorder,
    wait_for,
)

from uav_insar_planner.demo.processes import executable
from uav_insar_planner.mission_file.geodesy import latlon_to_ned
from uav_insar_planner.param_specs.nodes import FIRST_SYSID
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, uav_name, uavs
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_planner.track.passes import run_in_m
from uav_insar_sim.netlab.dds_env import dds_env
from uav_insar_sim.netlab.lab import NetLab

UAVS = uavs(DEFAULT_NUM_UAVS)
HOST_NAMES = ["ground", *(uav_name(k) for k in UAVS)]
N_SLOTS = 12  # 12 slots of 1 s at Table I's 4.3 m/s: a 51.6 m pass, as test_sitl_wind.py
WIND_MPS = 5.0
WIND_DIR_DEG = sitl.WIND_DIR_DEG  # from the east: across the track (y = north)
TURBULENCE = 2.0
GPS_NOISE_M = 0.5  # SIM_GPS1_NOISE
BEARING_DEG = 0.0
ORIGIN_NED_M = (0.0, 0.0, 0.0)  # the track origin is the copters' home: beside the start
SITL_PORT = 5760  # -I0 on every UAV's own loopback
TRUTH_PORT = 5762  # SERIAL1 of the same instance
TRUTH_RATE_HZ = 10.0  # simulation time: SPEEDUP times that on the wall clock
HELPER = Path(__file__).resolve().parent / "simstate_recorder.py"


def home() -> tuple[float, float]:
    """The copters' home (latitude, longitude) in degrees, from sitl_autopilot.HOME."""
    lat, lon = (float(v) for v in sitl.HOME.split(",")[:2])
    return lat, lon


def field_parameters() -> dict[str, float]:
    """The simulator's parameters of the field: wind across the track, GNSS noise."""
    return {"SIM_WIND_SPD": WIND_MPS, "SIM_WIND_DIR": WIND_DIR_DEG,
            "SIM_WIND_TURB": TURBULENCE, "SIM_GPS1_NOISE": GPS_NOISE_M}


def write_inputs(workdir: Path) -> tuple[Path, Path]:
    """The copters' parm file (field_parameters) and the nodes' ROS params file."""
    parm = workdir / "field.parm"
    parm.write_text("".join(f"{name} {value:g}\n" for name, value in field_parameters().items()))
    params = workdir / "params.yaml"
    params.write_text(yaml.safe_dump({"/**": {"ros__parameters": {
        "num_slots": N_SLOTS, "slot_duration_s": 1.0, "velocity_feedforward": True,
        # one slot more than the mission, so every UAV crosses the line after its last slot
        "track_duration_s": float(N_SLOTS + 1)}}}))
    return parm, params


@dataclass
class Flight:
    """What one `fly` left: the processes' outputs by name, the bag and truth files, and when
    each stage was reached (s after the start)."""

    out: dict[str, Output]
    bag: Path
    truth: dict[int, Path]
    times: dict[str, float] = field(default_factory=dict)


def start_hosts(lab: NetLab, domain: int, workdir: Path) -> Flight:
    """Start every process of the module doc; their outputs are read as they come."""
    parm, params = write_inputs(workdir)
    env = dds_env("subnet", [], {**base_env(), "ROS_DOMAIN_ID": str(domain)})
    flight = Flight({}, workdir / "bag", {})
    ros = ["--ros-args", "--params-file", str(params)]

    def start(host: str, name: str, cmd: list[str]) -> None:
        proc = lab.start(host, cmd, env=env, stderr=subprocess.STDOUT)
        flight.out[name] = Output(proc, name)

    for k in UAVS:
        host, sysid = uav_name(k), FIRST_SYSID + k
        copter = workdir / f"copter{k}"
        copter.mkdir()
        # each SITL is instance 0 of its own host: the same ports, on different loopbacks
        with open(copter / "sitl.log", "w") as log:
            lab.start(host, sitl.sitl_command(sysid, parm), cwd=copter, stdout=log,
                      stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        flight.truth[k] = copter / "simstate.csv"
        with open(copter / "simstate.log", "w") as log:
            lab.start(host, [sys.executable, str(HELPER), f"127.0.0.1:{TRUTH_PORT}",
                             str(flight.truth[k]), "--rate-hz", str(TRUTH_RATE_HZ),
                             *(f"--param={name}" for name in field_parameters())],
                      stdout=log, stderr=subprocess.STDOUT)
        start(host, f"bridge{k}", [
            *executable("mavlink_bridge"), *ros, "-r", f"__ns:=/{host}", "-p", f"uav_id:={k}",
            "-p", f"connections:=['tcp:127.0.0.1:{SITL_PORT}']",
            "-p", f"target_sysids:=[{sysid}]", "-p", "arm_and_takeoff:=true",
            "-p", f"track_bearing_deg:={BEARING_DEG}",
            "-p", f"origin_ned_m:=[{', '.join(str(v) for v in ORIGIN_NED_M)}]"])
        start(host, f"agent{k}", [*executable("agent"), *ros, "-r", f"__ns:=/{host}",
                                  "-p", f"uav_id:={k}", "-p", "position_source:=autopilot"])
    start("ground", "planner", [*executable("planner"), *ros])
    start("ground", "recorder", [*executable("uav-insar"), "record", str(flight.bag)])
    return flight


def fly(lab: NetLab, domain: int, workdir: Path, timeout_s: float = 170.0) -> Flight:
    """Start the hosts, wait until every agent completed its N_SLOTS slots, then close the bag
    (after three Fast DDS heartbeat periods, so a last sample lost on the radio is resent, as
    test_swarm_across_hosts.py). AssertionError with the logs when the mission did not end."""
    t0 = time.monotonic()
    flight = start_hosts(lab, domain, workdir)
    out = flight.out
    procs = [o.proc for o in out.values()]
    done = {k: f"{uav_name(k)}: mission complete: {N_SLOTS} slots" for k in UAVS}
    try:
        ok = wait_for(lambda: all(out[f"agent{k}"].first(done[k]) for k in UAVS), timeout_s,
                      procs)
        assert ok, "the mission did not complete:\n" + "\n".join(
            f"== {n}\n{o.text()[-2500:]}" for n, o in out.items())
        flight.times["missions_complete_s"] = time.monotonic() - t0
        time.sleep(3 * FAST_DDS_HEARTBEAT_S + 1.0)
        stop_recorder(out)
        flight.times["bag_closed_s"] = time.monotonic() - t0
    finally:  # every node's output beside the bag, for whoever reads a failure
        for name, o in out.items():
            (workdir / f"{name}.log").write_text(o.text() + "\n")
    return flight


# -- the same hosts with real PX4 SITL (test_sitl_px4_hosts.py) ---------------------------------
# Each UAV's namespace has a loopback of its own, but PX4 SITL's client/server sockets and lock
# files are /tmp/px4-sock-N and /tmp/px4_lock-N, shared by every namespace: instances 7, 8, 9
# keep clear of a localhost PX4 flight's 0, 1, 2 (their sysids are 8, 9, 10; ports move by N).
PX4_INSTANCE0 = 7
PX4_TRUTH_HELPER = Path(__file__).resolve().parent / "px4_truth_recorder.py"


@dataclass
class Px4Flight(Flight):
    """A Flight of PX4 vehicles: each one's process and px4.log; `complete` when every agent
    completed its slots, `broke` when a simulator's sensors failed first."""

    px4: dict[int, subprocess.Popen] = field(default_factory=dict)
    px4_logs: dict[int, Path] = field(default_factory=dict)
    complete: bool = False
    broke: bool = False


def start_px4_hosts(lab: NetLab, domain: int, workdir: Path) -> Px4Flight:
    """In uavK's namespace: px4_truth_recorder.py (SIH's truth on its loopback), PX4 SITL
    instance PX4_INSTANCE0 + k from its own home (sitl_px4.vehicle_home), its bridge and agent
    (sitl_px4.bridge_command, agent_command); on the ground the planner and the recorder. All
    of the localhost flight's parameters (sitl_px4.N_SLOTS slots, velocity feed-forward)."""
    env = dds_env("subnet", [], {**base_env(), "ROS_DOMAIN_ID": str(domain)})
    flight = Px4Flight({}, workdir / "bag", {})

    def start(host: str, name: str, cmd: list[str]) -> None:
        proc = lab.start(host, cmd, env=env, stderr=subprocess.STDOUT)
        flight.out[name] = Output(proc, name)

    for k in UAVS:
        host, instance = uav_name(k), PX4_INSTANCE0 + k
        folder = workdir / f"px4_{k}"
        folder.mkdir()
        flight.truth[k], flight.px4_logs[k] = folder / "truth.csv", folder / "px4.log"
        with open(folder / "truth.log", "w") as log:
            lab.start(host, [sys.executable, str(PX4_TRUTH_HELPER), str(instance),
                             str(flight.truth[k])], stdout=log, stderr=subprocess.STDOUT)
        cmd, px4_env = px4.px4_launch(k, folder, instance)
        with open(flight.px4_logs[k], "w") as log:
            flight.px4[k] = lab.start(host, cmd, env=px4_env, cwd=folder, stdout=log,
                                      stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        start(host, f"bridge{k}", px4.bridge_command(k, instance))
        start(host, f"agent{k}", px4.agent_command(k))
    start("ground", "planner", [*executable("planner"), "--ros-args",
                                "-p", f"num_slots:={px4.N_SLOTS}"])
    start("ground", "recorder", [*executable("uav-insar"), "record", str(flight.bag)])
    return flight


PX4_DONE = re.compile(r"uav(\d+): mission complete: (\d+) slots flown, (\d+) at the planned "
                      r"speed.*rate met in (\d+)")


def fly_px4(lab: NetLab, domain: int, workdir: Path, timeout_s: float = 150.0) -> Px4Flight:
    """Start the PX4 hosts and wait until every agent completed its slots (then close the bag
    as `fly` does), a simulator's sensors failed (sitl_px4.simulator_faults), a process ended
    or `timeout_s` passed; the test judges which."""
    t0 = time.monotonic()
    flight = start_px4_hosts(lab, domain, workdir)
    out = flight.out
    procs = [o.proc for o in out.values()] + list(flight.px4.values())

    def ended() -> bool:
        flight.broke = any(px4.simulator_faults(log.read_text())
                           for log in flight.px4_logs.values())
        flight.complete = all(PX4_DONE.search(out[f"agent{k}"].text()) for k in UAVS)
        return flight.broke or flight.complete

    try:
        wait_for(ended, timeout_s, procs)
        if flight.complete:
            flight.times["missions_complete_s"] = time.monotonic() - t0
            time.sleep(3 * FAST_DDS_HEARTBEAT_S + 1.0)
            stop_recorder(out)
            flight.times["bag_closed_s"] = time.monotonic() - t0
    finally:
        for name, o in out.items():
            (workdir / f"{name}.log").write_text(o.text() + "\n")
    return flight


def read_timed(bag: Path) -> dict[str, list[tuple[float, float, object]]]:
    """topic -> [(log time, publish time, message)] in the order written: log time when the
    ground received it, publish time the sender's own clock at sending (the bag's MCAP
    publish_time, the DDS source timestamp); seconds of time.time()."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (mcap_file,) = bag.glob("*.mcap")
    topics: dict[str, list] = {}
    with mcap_file.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message, msg in reader.iter_decoded_messages():
            topics.setdefault(channel.topic, []).append(
                (message.log_time * 1e-9, message.publish_time * 1e-9, msg))
    return topics


def truth_rows(path: Path, frame: TrackFrame) -> np.ndarray:
    """The simulator's truth (simstate_recorder.py's CSV) as (t, x, y, z) rows in the track
    frame. Heights are above the first row's altitude, the copter at rest on its home, where
    the autopilot's own local frame has its zero."""
    raw = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    lat0, lon0 = home()
    ground = raw[0, 3]
    off = math.hypot(*latlon_to_ned(lat0, lon0, raw[0, 1] * 1e-7, raw[0, 2] * 1e-7))
    assert off < 0.1, f"{path}: the first truth row is {off:.2f} m from home, not on it"
    rows = []
    for t, lat, lng, alt in raw:
        n, e = latlon_to_ned(lat0, lon0, lat * 1e-7, lng * 1e-7)
        rows.append((t, *frame.from_ned(n, e, ground - alt)))
    return np.array(rows)


def stamp_s(msg) -> float:
    """The header stamp of `msg` (a Header itself, or a message with one) in seconds."""
    stamp = getattr(msg, "header", msg).stamp
    return stamp.sec + 1e-9 * stamp.nanosec


def on_pass(rows: np.ndarray, t_start: float, y0: float, y1: float) -> np.ndarray:
    """The (t, x, y, z) rows at or after `t_start` with y0 <= y <= y1."""
    return rows[(rows[:, 0] >= t_start) & (rows[:, 2] >= y0) & (rows[:, 2] <= y1)]


def error_stats(rows: np.ndarray, target: np.ndarray) -> dict[str, dict[str, float]]:
    """Across-track (x - x_k) and height (z - z_k) errors of `rows`: sitl_autopilot.stats."""
    return {"across": sitl.stats(rows[:, 1] - target[0]),
            "height": sitl.stats(rows[:, 3] - target[2])}


def uav_figures(flight: Flight, timed: dict, k: int, t_start: float, target: np.ndarray,
                y_lines: tuple[float, float], rate_floor_bps: float) -> dict:
    """One UAV's figures (module doc); times in s relative to the pass start `t_start`."""
    name = uav_name(k)
    offloads = timed.get(f"/{name}/offload", [])
    rates = np.array([m.data for _, _, m in timed.get(f"/{name}/achieved_rate", [])])
    autopilot = np.array([(stamp_s(m), m.pose.position.x, m.pose.position.y, m.pose.position.z)
                          for _, _, m in timed.get(f"/{name}/mavlink/pose", [])]).reshape(-1, 4)
    truth = truth_rows(flight.truth[k], TrackFrame.from_degrees(BEARING_DEG, ORIGIN_NED_M))
    ap_pass, true_pass = (on_pass(rows, t_start, *y_lines) for rows in (autopilot, truth))
    reached = autopilot[(autopilot[:, 0] >= t_start) & (autopilot[:, 2] >= y_lines[0])]
    agent = flight.out[f"agent{k}"]

    def logged(proc: str, pattern: str) -> float:
        t = flight.out[f"{proc}{k}"].first(pattern)
        return math.nan if t is None else t - t_start

    return {
        # when the agent and the bridge heard the planner's start (their log lines' stamps)
        "start_heard_s": logged("agent", r"pass start .*wall clock"),
        "bridge_heard_s": logged("bridge", r"pass start from the planner"),
        "slots": [int(m.data[0]) for _, _, m in offloads],
        "slot0_sent_s": offloads[0][1] - t_start if offloads else math.nan,
        "slot0_received_s": offloads[0][0] - t_start if offloads else math.nan,
        "slot0_logged_s": logged("agent", r"slot 0 start"),
        "line_reached_s": reached[0, 0] - t_start if len(reached) else math.nan,
        "rates_bps": rates, "missed": [n for n, r in enumerate(rates) if r < rate_floor_bps],
        "missed_lines": [line for _, line in agent.lines if "missed R_min" in line],
        "autopilot": error_stats(ap_pass, target) if len(ap_pass) else {},
        "truth": error_stats(true_pass, target) if len(true_pass) else {},
        "autopilot_xz": ap_pass[:, [1, 3]].mean(axis=0) if len(ap_pass) else np.full(2, np.nan),
        "truth_xz": true_pass[:, [1, 3]].mean(axis=0) if len(true_pass) else np.full(2, np.nan),
        "poses": (len(autopilot), len(ap_pass)), "truth_rows": (len(truth), len(true_pass)),
        "sim_parameters": read_back(flight.truth[k]),
    }


def read_back(truth: Path) -> dict[str, float]:
    """The parameters simstate_recorder.py read back from the simulator beside `truth`."""
    path = Path(f"{truth}.params")
    lines = path.read_text().split("\n") if path.exists() else []
    return {name: float(value) for name, value in (line.split() for line in lines if line)}


def figures(flight: Flight) -> dict:
    """Every figure of the module doc from the bag, the truth files and the outputs."""
    from uav_insar_planner import load_params
    from uav_insar_planner.bag.reader import read_mission
    from uav_insar_planner.evaluate import evaluate, rate_tolerance_bps
    from uav_insar_planner.report.recorded import flown_scenario, mission_figures

    record = read_mission(flight.bag)
    params = flown_scenario(record, load_params(overrides={"num_slots": N_SLOTS}))
    report = mission_figures(record, params)
    timed = read_timed(flight.bag)
    starts = sorted({stamp_s(m) for _, _, m in timed.get("/formation/start", [])})
    assert starts, "no formation/start reached the ground"
    formation = record.formation
    y0 = float(formation[UAVS[0], 1])
    y_lines = (y0, y0 + N_SLOTS * params.speed * params.slot_duration_s)
    tol = rate_tolerance_bps(params.rate_min_bps)
    per_uav = {k: uav_figures(flight, timed, k, starts[0], formation[k], y_lines,
                              params.rate_min_bps[k] - tol) for k in UAVS}
    planned = formation[:, [0, 2]]

    def sigma(key: str) -> float:
        xz = planned.copy()
        for k in UAVS:
            xz[k] = per_uav[k][key]
        return float(evaluate(params, xz, record.power, report.scheme).sigma_h)

    rates = [r for k in UAVS for r in per_uav[k]["rates_bps"]]
    v = params.speed  # when the pass clock puts the target on slot 0's line, after the run-in
    due = PassClock(0.0, v, -run_in_m(v)).time_at(0.0)
    return {"starts": starts, "times": flight.times, "uav": per_uav, "planned_xz": planned,
            "slot0_due_s": due,
            "rate_min_bps": params.rate_min_bps, "tolerance_bps": tol,
            "met_share": (sum(len(per_uav[k]["rates_bps"]) - len(per_uav[k]["missed"])
                              for k in UAVS) / len(rates)) if rates else 0.0,
            "sigma_h_plan_m": report.sigma_h_plan_m,
            "sigma_h_report_m": report.sigma_h_flown_m,  # agents' uavK/pose, slot windows
            "sigma_h_autopilot_m": sigma("autopilot_xz"), "sigma_h_truth_m": sigma("truth_xz")}


def table(f: dict) -> str:
    """The measured figures as text (what the test prints)."""
    out = [f"wind {WIND_MPS:g} m/s from {WIND_DIR_DEG:g} deg, turbulence {TURBULENCE:g}, GNSS "
           f"noise {GPS_NOISE_M:g} m, radio {RADIO}; "
           + ", ".join(f"{k} {v:.1f} s" for k, v in f["times"].items()),
           f"pass start(s) from the planner: {', '.join(f'{t:.3f}' for t in f['starts'])}"]
    for k, u in f["uav"].items():
        out.append(f"  {uav_name(k)}: start heard by the agent {u['start_heard_s']:+.2f} s, "
                   f"by the bridge {u['bridge_heard_s']:+.2f} s;"
                   f" slot 0 sent {u['slot0_sent_s']:+.2f} s, received "
                   f"{u['slot0_received_s']:+.2f} s, logged {u['slot0_logged_s']:+.2f} s after "
                   f"the pass start (autopilot at the line {u['line_reached_s']:+.2f} s); "
                   f"{len(u['rates_bps'])} rates, missed R_min in slots {u['missed']}, "
                   f"{len(u['missed_lines'])} 'missed R_min' log lines")
        for source in ("autopilot", "truth"):
            e = u[source]
            if e:
                out.append(f"    {source:9s}: across-track error mean {e['across']['mean']:+.3f}"
                           f" std {e['across']['std']:.3f} |max| {e['across']['max_abs']:.3f} m;"
                           f" height error mean {e['height']['mean']:+.3f} std "
                           f"{e['height']['std']:.3f} |max| {e['height']['max_abs']:.3f} m")
        out.append(f"    poses on the pass: autopilot {u['poses'][1]} of {u['poses'][0]}, "
                   f"truth {u['truth_rows'][1]} of {u['truth_rows'][0]}")
    plan = f["sigma_h_plan_m"]
    out.append(f"  rate met in {100 * f['met_share']:.1f} % of slots (R_min - "
               f"{f['tolerance_bps']:g} bit/s)")
    out.append(f"  sigma_h: plan {plan:.5g} m; " + "; ".join(
        f"{name} {f[key]:.5g} m ({100 * (f[key] / plan - 1):+.2f} %)"
        for name, key in (("autopilot", "sigma_h_autopilot_m"), ("truth", "sigma_h_truth_m"),
                          ("report (agents' poses)", "sigma_h_report_m"))))
    return "\n".join(out)
