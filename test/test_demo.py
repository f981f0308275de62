"""`make demo` end to end: the demo module as a user runs it (a subprocess that starts the
planner, three agents, three MAVLink vehicles and the bridge as processes of their own; the
agents on position_source:=autopilot take their positions from the bridge-flown vehicles), and
the same brought up as one stack per UAV (`--per-uav-stacks`). The four runs that fly a
mission run side by side (the `demos` fixture), each checked by its own test."""
from __future__ import annotations

import re
import subprocess
import sys
from concurrent.futures import Future, ThreadPoolExecutor

import process_group
import pytest

pytestmark = pytest.mark.timeout(90)
DEMO = [sys.executable, "-m", "uav_insar_planner.demo"]
SLOTS_LINE = re.compile(r"uav(\d): x= *[-\d.]+ m z= *[-\d.]+ m  10/10 slots, (rate met in every "
                        r"slot|missed in \d+), worst margin ([-+\d.e]+) bit/s")
MAVLINK_LINE = re.compile(r"uav(\d) via MAVLink: across-track error max ([\d.]+) m, "
                          r"final ([\d.]+) m; flew ([-\d.]+) m along track \(pass ([\d.]+) m\)")


@pytest.fixture(scope="module")
def demos(tmp_path_factory) -> dict[str, Future]:
    """The four demo runs that fly a mission, started side by side (each on a ROS domain of its
    own, its vehicles on free ports; each mostly waits for its flight, in real time or at
    --time-scale 40): name -> the future of (CompletedProcess, bag)."""
    from conftest import REPO, _next_domain

    tmp = tmp_path_factory.mktemp("demos")
    runs = {  # name: (options, bag, timeout, stderr into stdout)
        "chain": (["--num-slots", "10"], tmp / "demo_bag", 60, False),
        "stacks": (["--per-uav-stacks", "--num-slots", "6"], tmp / "stacks_bag", 80, True),
        "no_mavlink": (["--num-slots", "5", "--time-scale", "40", "--no-mavlink"], None, 60,
                       False),
        "closed_loop": (["--num-slots", "8", "--time-scale", "40", "--no-mavlink",
                         "--offloading", "closed", "--fading", "--wind", "5", "0", "0",
                         "--seed", "3"], None, 60, False)}

    def run(options: list[str], bag, timeout: float, merged: bool):
        where = ["--bag", str(bag)] if bag else ["--no-bag"]
        streams = {"stdout": subprocess.PIPE, "stderr": subprocess.STDOUT} if merged else {
            "capture_output": True}
        return process_group.run([*DEMO, *options, "--domain-id", str(_next_domain()), *where],
                                 cwd=REPO, text=True, timeout=timeout, **streams), bag

    with ThreadPoolExecutor(len(runs)) as pool:
        return {name: pool.submit(run, *how) for name, how in runs.items()}


def test_demo_flies_the_whole_chain_and_exits_0(demos):
    proc, bag = demos["chain"].result()
    out = proc.stdout
    assert proc.returncode == 0, out + proc.stderr
    summary = out[out.index("\nsummary"):]
    # Every slot reported, its rate from where the vehicle was: the plan sits on R_min, so a
    # vehicle a few cm off it may miss R_min by a little. Bound: R ~ 1/d^2 at this SNR, so a
    # shortfall is at most 2 e / d of R_min for an error e; e < 0.5 m (below), d > 50 m: 2 %.
    slots = {int(m[1]): m for m in SLOTS_LINE.finditer(summary)}
    assert sorted(slots) == [0, 1, 2], summary
    rate_min_bps = (10e6, 16.95e6, 1e6)
    for k, m in slots.items():
        assert float(m[3]) >= -0.02 * rate_min_bps[k], m[0]
    vehicles = {int(m[1]): m for m in MAVLINK_LINE.finditer(summary)}
    assert sorted(vehicles) == [0, 1, 2], summary
    for m in vehicles.values():
        assert float(m[2]) < 0.5 and float(m[3]) < 0.5, m[0]  # across-track, on the pass
        assert float(m[4]) == pytest.approx(float(m[5]), abs=0.5), m[0]  # flew the pass
    assert "(position_source autopilot)" in out
    assert re.search(r"demo: stopped .* \(exit codes \[(0, ){7}0\]\)", out), out[-500:]
    assert f"to {bag} (recorder exit code 0)" in out
    from test_bag_record import assert_both_readers_decode

    assert_both_readers_decode(bag, mavlink=True, slots=10)


def test_demo_without_mavlink_starts_no_bridge(demos):
    proc, _ = demos["no_mavlink"].result()
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "[bridge]" not in proc.stdout and "MAVLink" not in proc.stdout
    assert "(exit codes [0, 0, 0, 0])" in proc.stdout


def test_bad_demo_option_exits_2(repo):
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.demo",
                           "--mavlink-base-port", "70000"], cwd=repo, capture_output=True,
                          text=True, timeout=30)
    assert proc.returncode == 2 and "--mavlink-base-port" in proc.stderr


def test_self_flown_options_without_no_mavlink_exit_2(repo):
    """--time-scale, --noise-std and --wind move self-flown agents only; the MAVLink path's
    agents ride on the vehicles, so they are refused there, not silently ignored."""
    for option in (["--time-scale", "5"], ["--noise-std", "0.1"], ["--wind", "1", "0", "0"]):
        proc = process_group.run([sys.executable, "-m", "uav_insar_planner.demo", *option],
                              cwd=repo, capture_output=True, text=True, timeout=30)
        assert proc.returncode == 2, option
        (line,) = proc.stderr.strip().splitlines()[-1:]
        assert f"{option[0]}: applies to self-flown agents only" in line, proc.stderr


def test_demo_flies_closed_loop_under_fading_and_wind(demos):
    proc, _ = demos["closed_loop"].result()
    assert proc.returncode == 0, proc.stdout + proc.stderr
    summary = proc.stdout[proc.stdout.index("\nsummary"):]
    energies = [float(e) for e in re.findall(r"energy ([\d.]+) of 594 J", summary)]
    assert len(energies) == 3 and all(0.0 < e <= 594.0 for e in energies), summary
    assert "offloading:=closed" not in proc.stderr


def test_bad_wind_exits_2(repo):
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.demo", "--wind", "99", "0",
                           "0"], cwd=repo, capture_output=True, text=True, timeout=30)
    assert proc.returncode == 2 and "--wind" in proc.stderr


def test_demo_flies_one_stack_per_uav(demos):
    """--per-uav-stacks: a bridge per UAV in /uavK flying its own vehicle, the agents in
    /uavK, and the planner's one start for every pass; the mission still completes."""
    proc, bag = demos["stacks"].result()
    out = proc.stdout
    assert proc.returncode == 0, out[-4000:]
    starts = re.findall(r"\[uav(\d)\.mavlink_bridge\]: swarm: pass start from the planner "
                        r"\(plan (\S+ \S+)\): in [\d.]+ s, wall clock ([\d.]+)", out)
    assert sorted(int(k) for k, _, _ in starts) == [0, 1, 2], out[-4000:]
    assert len({(plan, t) for _, plan, t in starts}) == 1, starts  # one plan, one instant
    assert "swarm: formation established" not in out  # no bridge started a pass of its own
    summary = out[out.index("\nsummary"):]
    assert len(re.findall(r"6/6 slots", summary)) == 3, summary
    vehicles = {int(m[1]): m for m in MAVLINK_LINE.finditer(summary)}
    assert sorted(vehicles) == [0, 1, 2], summary
    for m in vehicles.values():
        assert float(m[2]) < 0.5, m[0]
        assert float(m[4]) == pytest.approx(float(m[5]), abs=0.5), m[0]
    assert re.search(r"demo: stopped agents, planner, vehicles, bridges \(exit codes "
                     r"\[(0, ){9}0\]\)", out), out[-500:]
    from test_bag_record import assert_both_readers_decode

    assert_both_readers_decode(bag, mavlink=True, slots=6)


def test_per_uav_stacks_need_the_mavlink_path(repo):
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.demo", "--per-uav-stacks",
                           "--no-mavlink"], cwd=repo, capture_output=True, text=True,
                          timeout=30)
    assert proc.returncode == 2, proc.stderr
    (line,) = proc.stderr.strip().splitlines()[-1:]
    assert "--per-uav-stacks" in line and "without --no-mavlink" in line, proc.stderr


def test_a_uav_id_in_a_params_file_is_refused_for_the_stacks_bridges(repo, tmp_path):
    params = tmp_path / "params.yaml"
    params.write_text("/uav1/mavlink_bridge:\n  ros__parameters:\n    uav_id: 2\n")
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.demo", "--per-uav-stacks",
                           "--params-file", str(params)], cwd=repo, capture_output=True,
                          text=True, timeout=30)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "uav_id: value 2 is not allowed in the demo" in proc.stderr, proc.stderr
    assert "/uavK's stack flies UAV K" in proc.stderr


@pytest.mark.parametrize("bad,field", [
    (["-p", "gcs_timeout_s:=0.5"], "gcs_timeout_s"),  # in the bridge's range, not its rule
    (["-p", "max_accel_mps2:=0.0"], "max_accel_mps2"),  # the agents'
    (["-p", "uav_timeout_s:=0.01"], "uav_timeout_s"),  # the planner's
    (["-p", "arm_and_takeoff:=3"], "arm_and_takeoff"),
    (["--num-slots", "0"], "num_slots"),  # was: 20 slots flown
    (["PARAMS_FILE"], "gcs_timeout_s"),  # a stack's own section
])
def test_a_bad_node_parameter_is_refused_before_anything_starts(repo, tmp_path, bad, field):
    """Every node's values (params file sections for its name, -p, the demo's own) are judged
    by the nodes' specs and the bridge's rules up front: one line, exit 2, no process started
    (nothing on stdout, where the demo says what it starts), in well under the seconds a
    started swarm would take to fail."""
    if bad == ["PARAMS_FILE"]:
        params = tmp_path / "params.yaml"
        params.write_text("/uav2/mavlink_bridge:\n  ros__parameters:\n    gcs_timeout_s: 0.5\n")
        bad = ["--params-file", str(params)]
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.demo", "--per-uav-stacks",
                              "--no-bag", *bad], cwd=repo, capture_output=True, text=True,
                             timeout=30)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    (line,) = proc.stderr.strip().splitlines()
    assert line.startswith(f"{field}: value ") and "expected" in line, line
    assert proc.stdout == "", proc.stdout
