"""Replanning with real processes and injected faults: an agent process killed with SIGKILL
in mid-mission (the fault), the planner and the other agents real `ros2 run`-style processes
on a private domain, watched over real rclpy; what the operator sees on `formation`,
`formation/power` and /diagnostics is asserted, and the new plan is re-checked with the
independent checker (evaluate.py). The demo's kill run (its own processes and domain) runs
beside the first test (test/side_by_side.py)."""
from __future__ import annotations

import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import process_group
import pytest
from clean_stop import stop_cleanly
from conftest import REPO
from diagnostic_msgs.msg import DiagnosticStatus
from side_by_side import flight

from uav_insar_planner import load_params, solve
from uav_insar_planner.evaluate import evaluate, rate_tolerance_bps
from uav_insar_planner.replanning import plans
from uav_insar_planner.ros.swarm_watch import SWARM_STATUS_NAME

pytestmark = pytest.mark.timeout(120)
CONFIG = str(Path(__file__).resolve().parents[1] / "config" / "params.yaml")
N = 40
TIME_SCALE = 4.0  # 40 slots of 1 s in 10 s of wall time
TIMEOUT_S = 2.0  # uav_timeout_s for these tests


def xz(msg) -> np.ndarray:
    return np.array([[p.position.x, p.position.z] for p in msg.poses])


def swarm_statuses(w) -> list:
    return [s for m in w.diagnostics for s in m.status if s.name == SWARM_STATUS_NAME]


def start_agents(procs, common, only=(0, 1, 2)):
    return {k: procs("agent", *common, "-p", f"uav_id:={k}", "-p", f"time_scale:={TIME_SCALE}",
                     "-r", f"__node:=agent{k}") for k in only}


def last_slot(w, k) -> int:
    return int(w.offloads[k][-1][0]) if w.offloads[k] else -1


def test_killed_slave_is_replanned_out_and_the_survivors_finish(watcher, procs, side_by_side):
    side_by_side.start("replanning")  # the demo's kill run (the last test) flies beside this
    params = load_params(CONFIG, {"num_slots": N})
    plan = solve(params)
    w = watcher
    common = ["--params-file", CONFIG, "-p", f"num_slots:={N}"]
    planner = procs("planner", *common, "-p", f"uav_timeout_s:={TIMEOUT_S}")
    assert w.spin_until(lambda: w.formations and w.powers, 30.0, [planner]), "no plan"
    # A planner started before its agents declares nobody lost, however long it waits.
    w.spin_until(lambda: False, TIMEOUT_S + 1.0)
    assert len(w.formations) == 1
    before = swarm_statuses(w)
    assert before and all(s.level == DiagnosticStatus.STALE for s in before), before[-1]

    agents = start_agents(procs, common)
    everyone = [planner, *agents.values()]
    assert w.spin_until(lambda: last_slot(w, 1) >= 6, 30.0, everyone), "no slots flown"
    agents[1].send_signal(signal.SIGKILL)
    killed_at = time.monotonic()
    agents[1].wait(10)
    assert len(w.formations) == 1  # nothing was lost before the kill
    assert w.spin_until(lambda: len(w.formations) >= 2, TIMEOUT_S + 3.0, [planner])
    latency = time.monotonic() - killed_at
    assert latency <= TIMEOUT_S + 1.0, latency
    assert w.spin_until(lambda: len(w.powers) >= 2, 2.0)

    new, power = w.formations[-1], w.powers[-1]
    q = xz(new)
    assert np.isnan(q[1]).all() and np.isfinite(q[[0, 2]]).all()
    assert w.spin_until(lambda: w.plan_status() is not None and "lost" in w.plan_status().message,
                        3.0)
    status = w.plan_status()
    values = {kv.key: kv.value for kv in status.values}
    n0 = int(values["lost_at_slot"])
    # Single-baseline puts uav2 where uav1 flew: the operator is warned that a lost UAV may
    # still be there.
    assert status.level == DiagnosticStatus.WARN, status.message
    assert "uav2's new target is 0.0" in status.message
    assert "across-track from where uav1 was last heard (it may still be there)" in \
        status.message
    assert status.message.startswith(f"uav1 lost at slot {n0} (no pose, rate or offload for")
    assert f"re-planned from slot {n0} without uav1: single-baseline for uav0 and uav2" in \
        status.message
    assert values["lost_uav"] == "uav1" and float(values["replan_latency_s"]) < 1.0
    # The independent checker on the problem left: from slot n0 with the energy left (open
    # loop: the plan's schedule so far).
    p_new = np.reshape(power.data, (3, N))
    assert (p_new[1] == 0).all()
    assert p_new[[0, 2], :n0] == pytest.approx(plan.p_com_w[[0, 2], :n0])
    energy = {k: plans.energy_left_j(params, plan.p_com_w, k, n0) for k in range(3)}
    problem = plans.remaining_problem(params, 1, (2,), n0, energy)
    rows = np.vstack([q[[0, 2]], [[np.nan, np.nan]]])
    tail = np.vstack([p_new[[0, 2], n0:], np.zeros((1, N - n0))])
    ev = evaluate(problem.params, rows, tail, "single-baseline")
    assert ev.feasible, ev.violated

    # Both survivors finish the mission on the new plan; the slot clock never restarted.
    survivors = [planner, agents[0], agents[2]]
    assert w.spin_until(lambda: last_slot(w, 0) == N - 1 and last_slot(w, 2) == N - 1, 30.0,
                        survivors), (last_slot(w, 0), last_slot(w, 2))
    w.spin_until(lambda: False, 0.3)
    tol = rate_tolerance_bps(params.rate_min_bps)
    for k in (0, 2):
        slots = [int(o[0]) for o in w.offloads[k]]
        assert slots == sorted(set(slots)) and slots[-1] == N - 1
        # once across, the survivor meets its R_min on the new plan's power
        assert min(w.rates[k][-5:]) >= params.rate_min_bps[k] - tol
        assert w.offloads[k][-1][1] == pytest.approx(p_new[k, -1])
    swarm = swarm_statuses(w)[-1]
    assert swarm.level == DiagnosticStatus.WARN and "uav1 lost at slot" in swarm.message
    out = stop_cleanly(survivors)[survivors.index(agents[2])]
    assert "mission complete: " in out, out


def test_killed_master_stops_the_mission_and_the_slaves_hold(watcher, procs):
    w = watcher
    common = ["--params-file", CONFIG, "-p", f"num_slots:={N}"]
    agents = start_agents(procs, common)
    assert w.spin_until(w.agents_matched, 20.0, list(agents.values())), "agents not seen"
    planner = procs("planner", *common, "-p", f"uav_timeout_s:={TIMEOUT_S}")
    everyone = [planner, *agents.values()]
    assert w.spin_until(lambda: last_slot(w, 0) >= 4, 40.0, everyone), "no slots flown"
    agents[0].send_signal(signal.SIGKILL)
    killed_at = time.monotonic()
    assert w.spin_until(lambda: len(w.formations) >= 2, TIMEOUT_S + 3.0, [planner])
    assert time.monotonic() - killed_at <= TIMEOUT_S + 1.0
    assert w.spin_until(lambda: len(w.powers) >= 2, 2.0)
    hold = w.formations[-1]
    assert np.isnan(xz(hold)).all()
    assert not np.any(w.powers[-1].data)
    assert w.spin_until(lambda: w.plan_failed(), 3.0)
    status = w.plan_status()
    assert status.message.startswith("mission cannot continue: master uav0 lost at slot ")
    n = int(status.message.split("at slot ")[1].split()[0])
    assert 4 < n < N
    # The slaves stop (they brake, then hover) and fly no more slots.
    w.spin_until(lambda: False, 1.5)
    slots = {k: last_slot(w, k) for k in (1, 2)}
    where = {k: w.poses[k][-1].pose.position for k in (1, 2)}
    w.spin_until(lambda: False, 1.0)
    for k in (1, 2):
        assert last_slot(w, k) == slots[k] < N - 1
        p = w.poses[k][-1].pose.position
        assert math.dist((p.x, p.y, p.z), (where[k].x, where[k].y, where[k].z)) < 1e-3
    swarm = [s for s in swarm_statuses(w)][-1]
    assert swarm.level == DiagnosticStatus.ERROR
    assert "holding position after" in stop_cleanly([planner, agents[1], agents[2]])[1]


@flight("demo-kill-uav", "replanning")
def demo_kill_uav(workdir: Path, domain: int) -> subprocess.CompletedProcess:
    """`make demo`'s kill run on its own domain (`workdir` is unused: --no-bag)."""
    return process_group.run(
        [sys.executable, "-m", "uav_insar_planner.demo", "--num-slots", "30", "--no-mavlink",
         "--no-bag", "--kill-uav", "2", "--at", "3", "--uav-timeout", str(TIMEOUT_S),
         "--domain-id", str(domain)],
        cwd=REPO, capture_output=True, text=True, timeout=90)


@pytest.mark.side_by_side("demo-kill-uav")
def test_demo_kill_uav_shows_the_replan_in_its_summary(side_by_side):
    import re

    proc = side_by_side.result("demo-kill-uav")
    out = proc.stdout
    assert proc.returncode == 0, out + proc.stderr
    summary = out[out.index("\nsummary"):]
    m = re.search(r"kill: agent2 killed \(SIGKILL\) at slot (\d+); new formation ([\d.]+) s "
                  r"later \(uav_timeout_s 2 s\)", summary)
    assert m and int(m[1]) >= 3 and float(m[2]) <= TIMEOUT_S + 1.0, summary
    assert re.search(r"plan: uav2 lost at slot \d+ .*re-planned from slot \d+ without uav2",
                     summary), summary
    assert summary.count("30/30 slots, rate met in every slot") == 2, summary
    assert "planner: detection to new formation" in summary
    assert "(exit codes [0, 0, -9, 0])" in out
