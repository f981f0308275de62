"""One mission on three ArduCopter SITL autopilots (../shared/sitl/), optionally in wind, with
agents on `position_source:=autopilot`: what test_sitl_wind.py asserts and
benchmarks/sitl_wind.py prints. Not a test file.

Processes, all on one private ROS domain: three `arducopter` instances (SERIAL0 on TCP
BASE_PORTS, one working directory each, wind from a parm file given to --defaults after
ArduPilot's copter.parm), `uav-insar record`, `mavlink_bridge` (arm_and_takeoff, track origin
ORIGIN_N_M north of home, so the copters reach the pass start from behind it, moving forward),
three agents and the planner. The watcher in this process keeps every uavK/mavlink/pose.

`fly` returns the figures: per UAV its across-track error x - x_k and height error z - z_k on
the pass (the poses between the first and the one-past-last slot line), mean, std and max; the
distance between the two slaves (3-D, uav2 interpolated at uav1's stamps) on the pass, against
the plan's; the report's sigma_h planned and flown (report.recorded on the bag); the bag.
"""
from __future__ import annotations

import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import process_group

REPO = Path(__file__).resolve().parent.parent
SITL_DIR = REPO.parent / "shared" / "sitl"
ARDUCOPTER = SITL_DIR / "arducopter"
SPEEDUP = 2  # as test_sitl.py: stable with three instances on a 2-core machine
HOME = "-35.363261,149.165230,584,353"
# SERIAL0 of each copter; SERIAL1/2 at +2/+3, its RC input at +1 and IRLock at +4 (UDP): clear
# of test_sitl.py's -I0..-I2, which flies side by side with this mission (side_by_side.py)
BASE_PORTS = (32200, 32210, 32220)
SYSIDS = (2, 3, 4)
ORIGIN_N_M = 20.0  # track y = N - 20: home is 20 m behind the pass start
N_SLOTS = 12  # 12 slots of 1 s at Table I's 4.3 m/s: a 51.6 m pass
WIND_DIR_DEG = 90.0  # from the east: across the track (y = north), pushing towards -x


def sitl_command(sysid: int, parm: Path, base_port: int | None = None, home: str = HOME
                 ) -> list[str]:
    """arducopter with ArduPilot's copter.parm and then `parm` as defaults, at `home` (lat,lon,
    alt,heading): instance 0 (SERIAL0 on TCP 5760), or with every port moved to `base_port`
    and after (BASE_PORTS)."""
    ports = [] if base_port is None else [
        "--base-port", str(base_port), "--rc-in-port", str(base_port + 1),
        "--irlock-port", str(base_port + 4)]
    return [str(ARDUCOPTER), "--model", "+", "--speedup", str(SPEEDUP), *ports, "-I0",
            "--sysid", str(sysid), "--defaults", f"{SITL_DIR / 'copter.parm'},{parm}",
            "--home", home]


def start_sitl(k: int, workdir: Path, parm: Path) -> subprocess.Popen:
    log = open(workdir / "sitl.log", "w")  # noqa: SIM115 - closed with the process
    return subprocess.Popen(sitl_command(SYSIDS[k], parm, BASE_PORTS[k]), cwd=workdir,
                            stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            start_new_session=True)


kill_group = process_group.kill_group


def stats(values: np.ndarray) -> dict[str, float]:
    """mean, std, min and max of `values`, and max_abs, the largest |value|."""
    return {"mean": float(values.mean()), "std": float(values.std()),
            "min": float(values.min()), "max": float(values.max()),
            "max_abs": float(np.abs(values).max())}


def pass_rows(msgs: list, y0: float, y1: float) -> np.ndarray:
    """(t, x, y, z) rows, header-stamp time, of the poses with y0 <= y <= y1."""
    rows = np.array([(m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec, m.pose.position.x,
                      m.pose.position.y, m.pose.position.z) for m in msgs]).reshape(-1, 4)
    return rows[(rows[:, 2] >= y0) & (rows[:, 2] <= y1)]


def fly(wind_mps: float, turbulence: float, workdir: Path, domain: int,
        timeout_s: float = 200.0) -> dict:
    """Fly one mission (module doc); AssertionError naming what did not happen in time."""
    import rclpy

    from uav_insar_planner import load_params
    from uav_insar_planner.bag.reader import read_mission
    from uav_insar_planner.demo.processes import ros_env, start_node, start_process, stop_nodes
    from uav_insar_planner.demo.recorder import recorder_ready, stop_recorder
    from uav_insar_planner.report.recorded import flown_scenario, mission_figures
    from uav_insar_planner.ros.tools.topic_watcher import TopicWatcher

    params = load_params(overrides={"num_slots": N_SLOTS})
    parm = workdir / "wind.parm"
    parm.write_text(f"SIM_WIND_SPD {wind_mps}\nSIM_WIND_DIR {WIND_DIR_DEG}\n"
                    f"SIM_WIND_TURB {turbulence}\n")
    env = dict(ros_env(domain), PYTHONPATH=str(REPO))
    env.pop("ROS_STATIC_PEERS", None)
    ctx = rclpy.Context()
    rclpy.init(args=["sitl"], context=ctx, domain_id=domain)
    w = TopicWatcher(ctx)
    bag = workdir / "bag"
    sitls: list[subprocess.Popen] = []
    nodes: list[subprocess.Popen] = []
    t0 = time.monotonic()
    try:
        for k in range(3):
            (workdir / f"copter{k}").mkdir()
            sitls.append(start_sitl(k, workdir / f"copter{k}", parm))
        nodes.append(start_process([sys.executable, "-m", "uav_insar_planner.cli", "record",
                                    str(bag)], env))
        connections = ", ".join(f"'tcp:127.0.0.1:{p}'" for p in BASE_PORTS)
        nodes.append(start_node("mavlink_bridge", [
            "-p", f"connections:=[{connections}]", "-p", "target_sysids:=[2, 3, 4]",
            "-p", "arm_and_takeoff:=true", "-p", "velocity_feedforward:=true",
            "-p", f"origin_ned_m:=[{ORIGIN_N_M}, 0.0, 0.0]",
            "-p", f"track_duration_s:={N_SLOTS + 1.0}"], env))
        nodes += [start_node("agent", ["-p", f"uav_id:={k}", "-p", f"num_slots:={N_SLOTS}",
                                       "-p", "position_source:=autopilot",
                                       "-r", f"__node:=agent{k}"], env) for k in range(3)]
        assert w.spin_until(lambda: w.agents_matched() and recorder_ready(w.node, w.uavs), 30.0,
                            nodes), "agents or recorder did not come up"
        nodes.append(start_node("planner", ["-p", f"num_slots:={N_SLOTS}"], env))
        assert w.spin_until(lambda: w.formations and all(
            len(w.rates[k]) >= N_SLOTS for k in range(3)), timeout_s, nodes), \
            f"slots reported: {[len(w.rates[k]) for k in range(3)]}"
        mission_s = time.monotonic() - t0
        w.spin_until(lambda: False, 1.5)
        code, _ = stop_recorder(nodes[0])
    finally:
        stop_nodes(nodes)
        for proc in sitls:
            kill_group(proc)
        w.destroy()
        ctx.try_shutdown()
    record = read_mission(bag)
    scenario = flown_scenario(record, params)
    report = mission_figures(record, scenario)
    formation = record.formation
    y0 = float(formation[0, 1])
    y1 = y0 + N_SLOTS * params.speed * params.slot_duration_s
    on_pass = {k: pass_rows(w.mavlink_poses[k], y0, y1) for k in range(3)}
    figures: dict = {"wind_mps": wind_mps, "turbulence": turbulence, "recorder": code,
                     "bag": bag,
                     "mission_s": round(mission_s, 1),
                     "slots": [len(w.rates[k]) for k in range(3)],
                     "offload_slots": [[int(o[0]) for o in w.offloads[k]] for k in range(3)],
                     "sigma_h_plan_m": report.sigma_h_plan_m,
                     "sigma_h_flown_m": report.sigma_h_flown_m,
                     "flown_xz": report.flown_xz, "planned_xz": formation[:, [0, 2]].tolist(),
                     "record": record, "mavlink_poses": {k: [
                         (m.pose.position.x, m.pose.position.y, m.pose.position.z)
                         for m in w.mavlink_poses[k]] for k in range(3)}}
    for k in range(3):
        rows = on_pass[k]
        figures[f"uav{k}_across_m"] = stats(rows[:, 1] - formation[k, 0])
        figures[f"uav{k}_height_m"] = stats(rows[:, 3] - formation[k, 2])
        figures[f"uav{k}_pass_poses"] = len(rows)
    a, b = on_pass[1], on_pass[2]
    inside = (a[:, 0] >= b[0, 0]) & (a[:, 0] <= b[-1, 0])
    other = np.column_stack([np.interp(a[inside, 0], b[:, 0], b[:, i]) for i in (1, 2, 3)])
    spacing = np.linalg.norm(a[inside, 1:] - other, axis=1)
    planned = float(math.dist(formation[1], formation[2]))
    figures["slave_spacing_planned_m"] = planned
    figures["slave_spacing_m"] = stats(spacing)
    figures["slave_spacing_error_m"] = stats(spacing - planned)
    return figures


def table(figures: dict) -> str:
    """The figures of one `fly` as a few lines of text."""
    f = figures
    out = [f"wind {f['wind_mps']:g} m/s from {WIND_DIR_DEG:g} deg, turbulence "
           f"{f['turbulence']:g}: mission {f['mission_s']:g} s, slots {f['slots']}"]
    s = f["slave_spacing_m"]
    out.append(f"  slave spacing (plan {f['slave_spacing_planned_m']:.3f} m): mean "
               f"{s['mean']:.3f} std {s['std']:.3f} min {s['min']:.3f} max {s['max']:.3f} m; "
               f"|error| max {f['slave_spacing_error_m']['max_abs']:.3f} m")
    for k in range(3):
        a, h = f[f"uav{k}_across_m"], f[f"uav{k}_height_m"]
        out.append(f"  uav{k}: across-track error mean {a['mean']:+.3f} std {a['std']:.3f} |max| "
                   f"{a['max_abs']:.3f} m; height error mean {h['mean']:+.3f} std "
                   f"{h['std']:.3f} |max| {h['max_abs']:.3f} m ({f[f'uav{k}_pass_poses']} poses)")
    out.append(f"  sigma_h: plan {f['sigma_h_plan_m']:.5g} m, flown {f['sigma_h_flown_m']:.5g} m")
    return "\n".join(out)
