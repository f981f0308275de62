"""Swarms of 2 and 5 UAVs through the suite (num_uavs, swarm.py's MIN_UAVS..MAX_UAVS; ten in
test_ten_uavs.py): the plan messages' readers, the planner's topics, an agent beyond the plan,
a slave lost in a five-UAV mission (real planner and agent processes on a private domain), the
demo with five vehicles flown over MAVLink by the bridge and recorded, and the report of that
bag.
"""
from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import process_group
import pytest
from geometry_msgs.msg import Pose, PoseArray

from uav_insar_planner.ros import plan_msgs
from uav_insar_planner.swarm import MAX_UAVS, MIN_UAVS, uav_name

pytestmark = pytest.mark.timeout(240)
SLOTS_LINE = re.compile(r"uav(\d): x= *[-\d.]+ m z= *[-\d.]+ m  6/6 slots, (rate met in every "
                        r"slot|missed in \d+), worst margin ([-+\d.e]+) bit/s")
REPO = Path(__file__).resolve().parents[1]
CONFIG = str(REPO / "config" / "params.yaml")
# R_min,k of Table I, the last slave's for the slaves beyond U2 (as the demo's --uavs fits it)
RATE_MIN = {2: "[10.0, 16.95]", 5: "[10.0, 16.95, 1.0, 1.0, 1.0]"}


def scenario(n: int, slots: int) -> list[str]:
    return ["--params-file", CONFIG, "-p", f"num_slots:={slots}", "-p", f"num_uavs:={n}",
            "-p", f"rate_min_mbps:={RATE_MIN[n]}"]


def formation_of(count: int) -> PoseArray:
    msg = PoseArray()
    msg.poses = [Pose() for _ in range(count)]
    for k, pose in enumerate(msg.poses):
        pose.position.x, pose.position.z = -30.0 - k, 50.0 + k
    return msg


@pytest.mark.parametrize("count", [MIN_UAVS, 5, MAX_UAVS])
def test_a_formation_of_any_swarms_size_is_read(count):
    assert len(plan_msgs.decode_formation(formation_of(count)).points) == count


@pytest.mark.parametrize("count", [MIN_UAVS - 1, MAX_UAVS + 1])
def test_a_formation_of_another_count_is_refused_in_one_line(count):
    with pytest.raises(plan_msgs.PlanMessageError) as err:
        plan_msgs.decode_formation(formation_of(count))
    text = str(err.value)
    assert text.startswith("formation: poses: value ") and f"{MIN_UAVS} to {MAX_UAVS} poses" in text
    assert "\n" not in text


def _watcher(ctx, n: int):
    from uav_insar_planner.ros.tools.topic_watcher import TopicWatcher

    return TopicWatcher(ctx, f"watch{n}", num_uavs=n)


@pytest.mark.parametrize("n", [2, 5])
def test_planner_publishes_one_pose_and_one_power_row_per_uav(ros_context, procs, n):
    """The planner's plan holds n poses and n power rows, every UAV flown; an agent whose
    uav_id is not in that plan says so in one line and flies nothing."""
    w = _watcher(ros_context, n)
    try:
        planner = procs("planner", *scenario(n, 10))
        # an agent set up for a swarm one larger than the planner's
        beyond = procs("agent", "--params-file", CONFIG, "-p", f"uav_id:={n}",
                       "-p", f"num_uavs:={n + 1}", "-p", f"rate_min_mbps:={[1.0] * (n + 1)}",
                       "-p", "num_slots:=10", "-r", f"__node:=agent{n}")
        assert w.spin_until(lambda: w.formations and w.powers, 60.0, [planner]), "no plan"
        formation = plan_msgs.decode_formation(w.formations[-1])
        power = plan_msgs.decode_power(w.powers[-1])
        assert len(formation.points) == n and all(p is not None for p in formation.points)
        assert power.p_com_w.shape == (n, 10) and (power.p_com_w > 0).any(axis=1).all()
        assert w.spin_until(lambda: False, 3.0) is False
        beyond.send_signal(signal.SIGINT)
        out, _ = beyond.communicate(timeout=20)
    finally:
        w.destroy()
    line = (f"{uav_name(n)}: uav_id {n} is not in {power.plan_id}, a plan of {n} UAVs "
            f"(uav0..{uav_name(n - 1)}); ignored")
    assert line in out, out[-2000:]
    assert "flying plan" not in out


def _last_slot(w, k: int) -> int:
    return int(w.offloads[k][-1][0]) if w.offloads[k] else -1


def test_a_slave_lost_from_five_is_replanned_to_four_and_the_survivors_finish(ros_context,
                                                                                procs):
    """Five agent processes and the planner; agent 3's process group is killed (the fault) in
    mid-mission: the planner publishes a plan with uav3's row NaN (power zero) and the other
    four finite, and uav0, 1, 2 and 4 fly every slot."""
    n, slots, lost = 5, 40, 3
    w = _watcher(ros_context, n)
    try:
        common = scenario(n, slots)
        planner = procs("planner", *common, "-p", "uav_timeout_s:=2.0")
        agents = {k: procs("agent", *common, "-p", f"uav_id:={k}", "-p", "time_scale:=4.0",
                           "-r", f"__node:=agent{k}") for k in range(n)}
        everyone = [planner, *agents.values()]
        assert w.spin_until(lambda: _last_slot(w, lost) >= 6, 90.0, everyone), "no slots"
        first = plan_msgs.decode_formation(w.formations[-1])
        assert all(p is not None for p in first.points)
        os.killpg(agents[lost].pid, signal.SIGKILL)
        agents[lost].wait(10)
        survivors = [k for k in range(n) if k != lost]
        alive = [planner, *(agents[k] for k in survivors)]
        assert w.spin_until(lambda: any(
            plan_msgs.decode_formation(f).points[lost] is None for f in w.formations), 30.0,
            alive), "no re-plan without uav3"
        assert w.spin_until(lambda: len(w.powers) >= 2, 5.0)
        new = plan_msgs.decode_formation(w.formations[-1])
        power = plan_msgs.decode_power(w.powers[-1])
        assert new.stamp == power.plan_id.stamp
        assert len(new.points) == n and new.points[lost] is None
        assert all(new.points[k] is not None and all(map(math.isfinite, new.points[k]))
                   for k in survivors)
        assert power.p_com_w.shape == (n, slots) and not power.p_com_w[lost].any()
        assert w.spin_until(lambda: all(_last_slot(w, k) == slots - 1 for k in survivors),
                            90.0, alive), {k: _last_slot(w, k) for k in survivors}
        status = w.plan_status()
        assert status is not None and "uav3 lost at slot" in status.message, status
    finally:
        w.destroy()


def _run_group(cmd: list[str], timeout: float) -> tuple[int, str]:
    """Run `cmd` in its own process group; on timeout the whole group is killed."""
    try:
        done = process_group.run(cmd, cwd=REPO, stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT, text=True, timeout=timeout)
    except subprocess.TimeoutExpired as timed_out:
        pytest.fail(f"timed out:\n{(timed_out.output or '')[-3000:]}")
    return done.returncode, done.stdout


def test_demo_flies_five_vehicles_and_the_report_follows_the_bag(ros_domain, tmp_path):
    """`demo --uavs 5`: five agents, five vehicles flown by the bridge over MAVLink, recorded;
    `uav-insar report` of the bag has five UAVs in its table and a five-UAV layout."""
    bag = tmp_path / "five"
    code, out = _run_group([sys.executable, "-m", "uav_insar_planner.demo", "--uavs", "5",
                            "--num-slots", "6", "--bag", str(bag),
                            "--domain-id", str(ros_domain)], 200.0)
    assert code == 0, out[-4000:]
    assert "5 UAVs, 6 slots" in out and "MAVLink vehicles sysid 2..6" in out
    for k in range(5):
        assert f"{uav_name(k)}: x=" in out and f"{uav_name(k)} via MAVLink" in out, out[-3000:]
    # Every slot reported from where the vehicle was. The certified plan sits on R_min, so a
    # vehicle a few cm off may miss it by a little: at most 2 e / d of R_min for an error e
    # (R ~ 1/d^2 here), under 2 % for e < 0.5 m and d > 50 m (as test_demo's three UAVs).
    rate_min_bps = (10e6, 16.95e6, 1e6, 1e6, 1e6)
    slots = {int(m[1]): m for m in SLOTS_LINE.finditer(out)}
    assert sorted(slots) == list(range(5)), out[-3000:]
    for k, m in slots.items():
        assert float(m[3]) >= -0.02 * rate_min_bps[k], m[0]
    assert "uav5" not in out
    code, report = _run_group([sys.executable, "-m", "uav_insar_planner.cli", "report",
                               str(bag), "--out", str(tmp_path / "r"), "--no-progress"], 120.0)
    assert code == 0, report
    assert [f"{uav_name(k)}: on the track" in report for k in range(5)] == [True] * 5, report
    layout = json.loads((tmp_path / "r" / "foxglove_layout.json").read_text())
    labels = [p["label"] for p in layout["configById"]["Plot!rate"]["paths"]]
    assert labels == [uav_name(k) for k in range(5)]
    assert report.strip().splitlines()[-1].endswith(str(tmp_path / "r" / "foxglove_layout.json"))


def test_demo_flies_two_uavs_on_the_mission_clock(ros_domain):
    code, out = _run_group([sys.executable, "-m", "uav_insar_planner.demo", "--uavs", "2",
                            "--num-slots", "6", "--time-scale", "40", "--no-mavlink",
                            "--no-bag", "--domain-id", str(ros_domain)], 150.0)
    assert code == 0, out[-4000:]
    assert "2 UAVs, 6 slots" in out and "uav1 (R_min 16.95 Mbit/s)" in out
    assert "uav2" not in out


@pytest.mark.parametrize("argv,field", [
    (["--uavs", str(MAX_UAVS + 1)], f"--uavs: value {MAX_UAVS + 1} is not allowed; expected "
                                    f"{MIN_UAVS}..{MAX_UAVS}"),
    (["--uavs", "1"], "--uavs: value 1"),
    (["--uavs", "2", "--kill-uav", "2"], "--kill-uav: value 2")])
def test_a_bad_swarm_size_for_the_demo_exits_2_in_one_line(argv, field):
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.demo", *argv, "--no-bag"],
                          cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and field in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) <= 2  # argparse's usage line, then ours


def test_report_scenario_follows_the_recorded_swarm():
    from uav_insar_planner import load_params
    from uav_insar_planner.bag.reader import MissionRecord
    from uav_insar_planner.report.recorded import flown_scenario

    record = MissionRecord(formation=np.zeros((5, 3)), power=np.ones((5, 8)),
                           uav_values={3: {"rate_min_bps": "2e6"}})
    p = flown_scenario(record, load_params(CONFIG))
    assert (p.num_uavs, p.num_slots) == (5, 8)
    assert p.rate_min_bps == pytest.approx((10e6, 16.95e6, 1e6, 2e6, 1e6))
