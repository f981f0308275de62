"""`uav-insar report` on a bag of known content, written here with rosbags' own writer and
type store (not our writer or our message definitions), so every figure is known beforehand."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import process_group
import pytest
from conftest import REPO

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import default_params
from uav_insar_planner.swarm import MAX_UAVS, uav_color, uav_rgb

N = 5
T0_NS = 1_700_000_000 * 10**9
PLANNED = np.array([[-27.118, 47.118], [-34.854, 48.190], [-35.914, 49.251]])
POWER = np.array([[3.0] * N, [5.0] * N, [0.3] * N])
BUDGET_J = 594.0
UAV1_OFFSET = (0.6, -0.8)  # uav1 flies the whole track this far off: 1.0 m
P = default_params().replace(num_slots=N)


def _rate(k: int, n: int) -> float:
    """uav1 misses R_min by 2 Mbit/s in slots 1 and 3; the others beat it."""
    if k == 1 and n in (1, 3):
        return P.rate_min_bps[1] - 2e6
    return P.rate_min_bps[k] + (1e3 if k == 0 else 5e5)


def _applied(k: int, n: int) -> float:
    return 3.5 if (k, n) == (0, 2) else float(POWER[k, n])


def write_known_bag(path: Path, with_plan: bool = True) -> None:
    """Slots start at t = 10 + n s (uavK/offload, uavK/achieved_rate); poses every 0.5 s from
    t = 8 to 17 s, 10 m off before and after the track, on the plan (uav1: UAV1_OFFSET) on it."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    T = ts.types
    Header = T["std_msgs/msg/Header"]
    Time = T["builtin_interfaces/msg/Time"]
    Point, Quat = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    Pose = T["geometry_msgs/msg/Pose"]
    Layout, Dim = T["std_msgs/msg/MultiArrayLayout"], T["std_msgs/msg/MultiArrayDimension"]
    F64Array = T["std_msgs/msg/Float64MultiArray"]
    header = Header(stamp=Time(sec=0, nanosec=0), frame_id="insar_track")

    def pose(x: float, y: float, z: float):
        return Pose(position=Point(x=x, y=y, z=z), orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0))

    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as bag:
        def add(topic: str, msgtype: str):
            return bag.add_connection(topic, msgtype, typestore=ts)

        def put(conn, t: float, msg) -> None:
            bag.write(conn, T0_NS + int(round(t * 1e9)), ts.serialize_cdr(msg, conn.msgtype))

        if with_plan:
            put(add("/formation", "geometry_msgs/msg/PoseArray"), 1.0,
                T["geometry_msgs/msg/PoseArray"](header=header, poses=[
                    pose(x, 0.0, z) for x, z in PLANNED]))
            put(add("/formation/power", "std_msgs/msg/Float64MultiArray"), 1.0, F64Array(
                layout=Layout(dim=[Dim(label="uav", size=3, stride=3 * N),
                                   Dim(label="slot", size=N, stride=N)], data_offset=0),
                data=POWER.ravel()))
            status = T["diagnostic_msgs/msg/DiagnosticStatus"](
                level=0, name="planner: plan", message="ok", hardware_id="x",
                values=[T["diagnostic_msgs/msg/KeyValue"](key="scheme", value="proposed"),
                        T["diagnostic_msgs/msg/KeyValue"](key="sigma_h_m", value="0.0736")])
            put(add("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray"), 2.0,
                T["diagnostic_msgs/msg/DiagnosticArray"](header=header, status=[status]))
        for k in range(3):
            rate = add(f"/uav{k}/achieved_rate", "std_msgs/msg/Float64")
            off = add(f"/uav{k}/offload", "std_msgs/msg/Float64MultiArray")
            poses = add(f"/uav{k}/pose", "geometry_msgs/msg/PoseStamped")
            used = 0.0
            for n in range(N):
                used += _applied(k, n) * P.slot_duration_s
                put(rate, 10.0 + n, T["std_msgs/msg/Float64"](data=_rate(k, n)))
                put(off, 10.0 + n, F64Array(layout=Layout(dim=[], data_offset=0), data=np.array(
                    [n, _applied(k, n), used, BUDGET_J - used])))
            for t in np.arange(8.0, 17.01, 0.5):
                on_track = 10.0 <= t <= 15.0
                dx, dz = (UAV1_OFFSET if k == 1 else (0.0, 0.0)) if on_track else (10.0, 0.0)
                x, z = PLANNED[k]
                put(poses, float(t), T["geometry_msgs/msg/PoseStamped"](
                    header=header, pose=pose(x + dx, (t - 10.0) * P.speed, z + dz)))


@pytest.fixture(scope="module")
def known_bag(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("known") / "bag"
    write_known_bag(path)
    return path


def test_figures_of_a_known_bag(known_bag):
    from uav_insar_planner.bag.reader import read_mission
    from uav_insar_planner.report.recorded import mission_figures

    f = mission_figures(read_mission(known_bag), P)
    assert f.uavs == [0, 1, 2] and f.num_slots == N and f.scheme == "proposed"
    assert list(f.rates[1]) == [_rate(1, n) for n in range(N)]
    assert list(f.applied_w[0]) == [_applied(0, n) for n in range(N)]
    assert f.energy_j[0][-1] == pytest.approx(sum(_applied(0, n) for n in range(N)))
    assert all(b == pytest.approx(BUDGET_J) for b in f.budget_j.values())
    track = f.tracks[1]
    assert len(track.dx) == 11  # t = 10.0 ... 15.0: the poses before and after are not counted
    assert track.worst_error_m == pytest.approx(1.0)
    assert f.tracks[0].worst_error_m == pytest.approx(0.0, abs=1e-9)
    assert f.flown_xz[1] == pytest.approx((PLANNED[1, 0] + 0.6, PLANNED[1, 1] - 0.8))
    flown = PLANNED.copy()
    flown[1] += UAV1_OFFSET
    assert f.sigma_h_plan_m == pytest.approx(evaluate(P, PLANNED, POWER, "proposed").sigma_h)
    assert f.sigma_h_flown_m == pytest.approx(evaluate(P, flown, POWER, "proposed").sigma_h)
    assert f.sigma_h_flown_m != pytest.approx(f.sigma_h_plan_m, rel=1e-4)
    assert f.sigma_h_recorded_m == 0.0736


def test_every_uav_has_its_colour_past_the_largest_swarm():
    """One colour table for the report's plots and the markers: Table I's U0 red, U1 blue,
    U2 green, a colour of its own for each UAV a swarm may have (tab10's ten), and one (no
    IndexError) past the largest swarm, should MAX_UAVS grow."""
    import matplotlib.colors

    assert [uav_color(k) for k in range(3)] == [
        matplotlib.colors.to_hex(name) for name in ("tab:red", "tab:blue", "tab:green")]
    assert len({uav_color(k) for k in range(MAX_UAVS)}) == MAX_UAVS
    for k in range(3 * MAX_UAVS):
        assert matplotlib.colors.to_rgb(uav_color(k)) == pytest.approx(uav_rgb(k))


def test_report_cli_prints_the_table_and_writes_the_plots(known_bag, tmp_path):
    out = tmp_path / "plots"
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "report",
                           str(known_bag), "--out", str(out), "--no-progress"],
                          capture_output=True, text=True, timeout=60, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    text = proc.stdout
    assert "uav0:" in text and f"{N}/{N} slots, rate met in every slot" in text
    assert f"{N}/{N} slots, missed in 2, worst margin -2e+06 bit/s" in text
    used0 = sum(_applied(0, n) for n in range(N))
    assert f"energy {used0:.1f} of {BUDGET_J:g} J" in text
    assert "uav1: on the track 11 poses, worst position error 1.000 m (across-track 0.600 m, " \
           "height 0.800 m)" in text
    sigma = evaluate(P, PLANNED, POWER, "proposed").sigma_h
    assert f"sigma_h: plan {sigma:.4g} m (planner: 0.0736 m)" in text
    pngs = sorted(p.name for p in out.iterdir())
    assert pngs == sorted(["report_rate.png", "report_power.png", "report_energy.png",
                           "report_error.png", "report_formation.png"])
    assert all((out / name).read_bytes()[:4] == b"\x89PNG" for name in pngs)


@pytest.mark.parametrize("case", ["missing", "not a bag", "no plan"])
def test_report_refuses_bad_bags_with_one_line(case, tmp_path):
    bag = tmp_path / "bag"
    if case == "not a bag":
        bag.mkdir()
    elif case == "no plan":
        write_known_bag(bag, with_plan=False)
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "report", str(bag),
                           "--no-progress"], capture_output=True, text=True, timeout=60,
                          cwd=REPO)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert proc.stderr.startswith("uav-insar report: error: ")
    assert not (tmp_path / "bag_report").exists()


def test_the_report_compares_the_flown_sigma_h_with_the_certified_worst_case(known_bag):
    """With nav_error_m = e the report bounds the plan's worst case within e and says whether
    the flown geometry stayed below it (uav1 flew 1.0 m off: beyond e = 0.5 m)."""
    from uav_insar_planner.bag.reader import read_mission
    from uav_insar_planner.report.recorded import mission_figures, report_table
    from uav_insar_planner.solver.worst_case import worst_sigma

    assert np.isnan(mission_figures(read_mission(known_bag), P).sigma_h_worst_m)
    robust = P.replace(nav_error_m=0.5)
    f = mission_figures(read_mission(known_bag), robust)
    assert f.sigma_h_worst_m == worst_sigma(robust, PLANNED, "proposed").upper
    assert f.sigma_h_worst_m > f.sigma_h_plan_m
    held = "within it" if f.sigma_h_flown_m <= f.sigma_h_worst_m else "ABOVE it"
    assert (f"sigma_h: certified worst case within nav_error_m = 0.5 m "
            f"{f.sigma_h_worst_m:.4g} m; flown {held}") in report_table(f, robust)
