"""The largest swarm, MAX_UAVS (ten: a master and nine slaves), through the suite: the demo's
options and every node's checks of them; ten agent processes flying the planner's ten-UAV
plan, recorded, the markers and the bag's uav9 topics, the report of that bag and its Foxglove
layout read against it; the bridge flying ten MAVLink vehicles (real UDP bytes) into the
planned formation; export-mission's ten files; the vehicles' default ports.

The plans here minimise Proposition 1's bound (`objective: bound`), which the certified solver
settles for ten UAVs in about a second; the exact objective takes ~25 s at ten UAVs until the
solver's K = 9 work lands (issue 29), and no test here is about the objective.
"""
from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import process_group
import pytest
from conftest import REPO
from test_foxglove_layout import _bag_messages, check_layout_reads_the_bag

from uav_insar_planner.cli import main as cli
from uav_insar_planner.exit_codes import EXIT_OK
from uav_insar_planner.param_specs.nodes import FIRST_PORT, FIRST_SYSID, vehicle_connection
from uav_insar_planner.report.foxglove_layout import foxglove_layout
from uav_insar_planner.report.recorded_plots import FILES
from uav_insar_planner.swarm import MAX_UAVS, uav_name, uav_rgb, uavs
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(120)
TEN = uavs(MAX_UAVS)
CONFIG = REPO / "config" / "params.yaml"
# Table I's R_min,k, the last slave's (1 Mbit/s) for the slaves beyond U2, as the demo fits it
RATES_MBPS = [10.0, 16.95] + [1.0] * (MAX_UAVS - 2)
SCENARIO = {"num_uavs": MAX_UAVS, "rate_min_mbps": RATES_MBPS, "objective": "bound"}
SETS = [a for name, v in SCENARIO.items() for a in ("--set", f"{name}={v}")]
ROS_ARGS = [a for name, v in SCENARIO.items() for a in ("-p", f"{name}:={v}")]
# The demo's agents fly their slots for SLOTS / TIME_SCALE s of wall time (Table I's 1 s slots):
# long enough for the planner, whose discovery of ten agents may take seconds, to hear each
# agent's rates and pose, so that its 1 Hz /diagnostics (each UAV's position error, a plot of
# the layout) is recorded for every UAV
SLOTS, TIME_SCALE = 20, 5.0


@pytest.mark.parametrize("mode", [[], ["--per-uav-stacks"], ["--no-mavlink"]])
def test_the_demo_takes_ten_uavs_and_every_node_would(mode):
    from uav_insar_planner.demo.node_checks import node_problems
    from uav_insar_planner.demo.options import fit_swarm, parse_options
    from uav_insar_planner.params_file import load_params

    args = parse_options(["--uavs", str(MAX_UAVS), "--kill-uav", str(MAX_UAVS - 1), "--no-bag",
                          *mode])
    overrides: dict = {}
    assert fit_swarm(args, overrides) == []
    assert overrides == {"num_uavs": MAX_UAVS, "rate_min_mbps": RATES_MBPS}
    params = load_params(CONFIG, overrides)
    assert params.num_uavs == MAX_UAVS and len(params.rate_min_bps) == MAX_UAVS
    assert node_problems(args, overrides, params) == []


def _demo(bag: Path, domain: int) -> str:
    cmd = [sys.executable, "-m", "uav_insar_planner.demo", "--uavs", str(MAX_UAVS),
           "--no-mavlink", "--num-slots", str(SLOTS), "--time-scale", str(TIME_SCALE),
           "-p", "objective:=bound", "--bag", str(bag), "--domain-id", str(domain)]
    try:
        done = process_group.run(cmd, cwd=REPO, stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT, text=True, timeout=100)
    except subprocess.TimeoutExpired as timed_out:
        pytest.fail(f"timed out:\n{(timed_out.output or '')[-3000:]}")
    assert done.returncode == 0, done.stdout[-4000:]
    return done.stdout


def _markers(messages: dict, topic: str, ns: str) -> dict[int, object]:
    return {m.id: m for array in messages[topic] for m in array.markers if m.ns == ns}


def test_ten_agents_fly_the_plan_recorded_and_reported(ros_domain, tmp_path):
    """`demo --uavs 10 --no-mavlink`: ten agent processes fly every slot of the planner's
    ten-UAV plan; the bag holds uav9's topics, ten poses and power rows, a planned marker per
    UAV in its colour and uav9's flown one; `uav-insar report` of it plots ten UAVs and
    writes the ten-UAV layout, whose every plot path reads numbers from the bag."""
    bag = tmp_path / "ten"
    out = _demo(bag, ros_domain)
    assert f"{MAX_UAVS} UAVs, {SLOTS} slots" in out, out[-3000:]
    for k in TEN:
        assert f"{uav_name(k)}: x=" in out and f"{SLOTS}/{SLOTS} slots, rate met in every slot" in \
            out.split(f"  {uav_name(k)}: x=")[1].splitlines()[0], out[-3000:]
    types, messages = _bag_messages(bag)
    last = uav_name(MAX_UAVS - 1)
    assert {f"/{last}/{t}" for t in ("achieved_rate", "offload", "pose")} <= set(types)
    assert len(messages[f"/{last}/achieved_rate"]) >= SLOTS
    poses = messages["/formation"][-1].poses
    assert len(poses) == MAX_UAVS and all(math.isfinite(p.position.x) for p in poses)
    assert messages["/formation/power"][-1].layout.dim[0].size == MAX_UAVS
    planned = _markers(messages, "/formation/markers", "planned")
    assert sorted(planned) == list(TEN)
    for k, m in planned.items():
        assert (m.color.r, m.color.g, m.color.b) == pytest.approx(uav_rgb(k))
        assert (m.pose.position.x, m.pose.position.z) == pytest.approx(
            (poses[k].position.x, poses[k].position.z))
    assert MAX_UAVS - 1 in _markers(messages, "/formation/markers/flown", "actual")

    report = tmp_path / "report"
    done = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "report", str(bag),
                              "--out", str(report), "--no-progress"], cwd=REPO,
                             capture_output=True, text=True, timeout=90)
    assert done.returncode == 0, done.stderr
    assert [f"{uav_name(k)}: on the track" in done.stdout for k in TEN] == [True] * MAX_UAVS
    # the demo's summary and the bag's agree, the last slot's energy included
    for k in TEN:
        line = f"  {uav_name(k)}: x="
        assert out.split(line)[1].splitlines()[0] == done.stdout.split(line)[1].splitlines()[0]
    assert all((report / name).stat().st_size > 0 for name in FILES)
    layout = json.loads((report / "foxglove_layout.json").read_text())
    assert layout == foxglove_layout(MAX_UAVS)
    check_layout_reads_the_bag(layout, bag)


def test_the_bridge_flies_ten_vehicles_into_the_planned_formation(procs, ros_context):
    """The planner's ten-UAV plan, one bridge wired to ten simulated vehicles over UDP (sysid
    2..11): every vehicle reaches its planned point, the bridge starts the pass at the
    planner's formation/start, uav9's autopilot pose is published, each link reported."""
    from uav_insar_planner.ros.plan_msgs import decode_formation
    from uav_insar_planner.ros.tools.topic_watcher import TopicWatcher

    w = TopicWatcher(ros_context, "watch_ten", num_uavs=MAX_UAVS)
    vehicles = [SimVehicle(FIRST_SYSID + k, "udpin:127.0.0.1:0", "ardupilot",
                           start_ned=(0.0, 3.0 * k, -50.0), max_speed=25.0, max_accel=10.0,
                           airborne=True) for k in TEN]
    for v in vehicles:
        v.start()
    try:
        ports = [f"udpout:127.0.0.1:{v.port}" for v in vehicles]
        everyone = [procs("mavlink_bridge", "-p", f"connections:={ports}",
                          "-p", f"target_sysids:={[v.sysid for v in vehicles]}",
                          "-p", "speed_mps:=2.0", "-p", "velocity_feedforward:=true"),
                    procs("planner", *ROS_ARGS, "-p", "speed_mps:=2.0")]  # the bridge's
        assert w.spin_until(lambda: w.formations, 60.0, everyone), "no plan"
        plan = decode_formation(w.formations[-1]).points
        assert len(plan) == MAX_UAVS and all(p is not None for p in plan)

        def off_plan() -> list[float]:  # bearing 0, origin 0: (x, z) = (E, -D)
            return [math.hypot(v.position_ned[1] - p[0], -v.position_ned[2] - p[2])
                    for v, p in zip(vehicles, plan, strict=True)]

        assert w.spin_until(lambda: max(off_plan()) < 0.5, 60.0, everyone), off_plan()
        held = np.array([v.position_ned[0] for v in vehicles])
        assert w.spin_until(lambda: (np.array([v.position_ned[0] for v in vehicles]) - held
                                     > 0.5).all(), 20.0, everyone), "the pass did not start"
        assert max(off_plan()) < 0.5
        last = w.mavlink_poses[MAX_UAVS - 1]
        assert last and last[-1].header.frame_id == "insar_track"
        linked = {s.name for m in w.diagnostics for s in m.status
                  if s.name.startswith("mavlink_bridge") and s.message.startswith("linked")}
        assert linked == {f"mavlink_bridge: {uav_name(k)}" for k in TEN}
    finally:
        w.destroy()
        for v in vehicles:
            v.stop()


def test_export_mission_writes_ten_plans_and_a_smaller_export_removes_them(tmp_path, capsys):
    home = ["--home", "-35.363261,149.165230,584.0", "--bearing", "0"]
    assert cli(["export-mission", *home, "--out", str(tmp_path), *SETS]) == EXIT_OK
    names = [f"{uav_name(k)}.plan" for k in TEN]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names)
    starts = {json.loads((tmp_path / n).read_text())["mission"]["items"][1]["params"][5]
              for n in names}
    assert len(starts) == MAX_UAVS  # ten distinct across-track positions (bearing 0: east)
    capsys.readouterr()
    assert cli(["export-mission", *home, "--out", str(tmp_path),
                "--formation", "-31,40,-37,45"]) == EXIT_OK
    out = capsys.readouterr().out
    assert f"removed {', '.join(names[2:])} from" in out, out
    assert sorted(p.name for p in tmp_path.iterdir()) == names[:2]


def test_a_sweep_and_a_map_run_over_swarm_sizes_up_to_ten(tmp_path):
    """`sweep num_uavs 2 10 9` and a map with num_uavs on one axis: Table I's rate list fitted
    to each size (swarm.fit_to_swarm), every point planned; more slaves never raise the least
    bound (each adds a baseline, and the smaller swarm's formation is still there to keep)."""
    sweep, grid = tmp_path / "sweep.csv", tmp_path / "map.csv"
    common = ["--objective", "bound", "--schemes", "proposed", "--jobs", "1", "--no-progress"]
    assert cli(["sweep", "num_uavs", "2", str(MAX_UAVS), str(MAX_UAVS - 1), *common,
                "--csv", str(sweep)]) == EXIT_OK
    rows = [r for r in csv.DictReader(line for line in sweep.read_text().splitlines()
                                      if not line.startswith("#"))]
    assert [float(r["value"]) for r in rows] == [float(n) for n in range(2, MAX_UAVS + 1)]
    assert all(r["feasible"] == "True" for r in rows), rows
    bounds = [float(r["sigma_h_bound_m"]) for r in rows]
    assert all(b <= a * (1 + 1e-6) for a, b in zip(bounds, bounds[1:], strict=False)), bounds
    assert cli(["map", "num_uavs", str(MAX_UAVS - 1), str(MAX_UAVS), "2", "h_amb_min_m", "1.0",
                "1.2", "2", *common, "--csv", str(grid)]) == EXIT_OK
    cells = [line for line in grid.read_text().splitlines()
             if line and not line.startswith(("#", "value1"))]
    assert len(cells) == 4 and all(",True," in c for c in cells), cells


def test_plot_formation_and_montecarlo_take_ten_uavs_and_refuse_eleven(tmp_path, capsys):
    formation_png, histograms_png = tmp_path / "formation.png", tmp_path / "mc.png"
    assert cli(["plot-formation", *SETS, "--out", str(formation_png)]) == EXIT_OK
    assert formation_png.stat().st_size > 10_000
    capsys.readouterr()
    assert cli(["solve", *SETS, "--json"]) == EXIT_OK
    plan = json.loads(capsys.readouterr().out)
    numbers = ",".join(f"{plan['formation'][uav_name(k)][axis]:.3f}" for k in TEN
                       for axis in ("x_m", "z_m"))
    assert cli(["montecarlo", f"--formation={numbers}", "--samples", "300", "--json",
                "--plot", str(histograms_png)]) == EXIT_OK
    pairs = json.loads(capsys.readouterr().out)["montecarlo"]["pairs"]
    assert list(pairs) == [uav_name(k) for k in TEN[1:]]
    assert histograms_png.stat().st_size > 10_000
    assert cli(["montecarlo", f"--formation={numbers},-70,80", "--samples", "300"]) != EXIT_OK
    err = capsys.readouterr().err.strip()
    assert err.startswith("uav-insar: error: --formation: value ") and "\n" not in err
    assert f"x{MAX_UAVS - 1},z{MAX_UAVS - 1}]" in err and f"or {2 * MAX_UAVS} finite" in err


# Fast DDS's default ports of domain d (PB 7400, DG 250, PG 2): multicast 7400 + 250 d (+1),
# unicast 7410 + 250 d + 2 p (+1) for participant p on a host
def _dds_ports(participants: int) -> set[int]:
    return {7400 + 250 * d + offset for d in range(233)
            for offset in (0, 1, *range(10, 12 + 2 * participants))}


def test_ten_vehicles_default_ports_are_distinct_and_clear_of_the_gcs_and_dds():
    """The bridge's default connection to vehicle k (FIRST_PORT + PORT_STEP k) for every k of
    the largest swarm: distinct, none the ground station's 14550, none a ROS domain's port
    while its host runs fewer than 60 participants."""
    ports = [int(vehicle_connection(k).rsplit(":", 1)[1]) for k in TEN]
    assert ports[0] == FIRST_PORT and len(set(ports)) == MAX_UAVS
    assert 14550 not in ports
    assert not set(ports) & _dds_ports(60)
