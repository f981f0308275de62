"""Launch-free bring-up with real processes: the installed `planner` and `agent` executables
started as `ros2 run` would, watched from this process over real rclpy."""
from __future__ import annotations

import signal
from pathlib import Path

import numpy as np
import pytest
from clean_stop import stop_cleanly

from uav_insar_planner import load_params, model, solve
from uav_insar_planner.evaluate import rate_tolerance_bps
from uav_insar_planner.swarm import MAX_UAVS

CONFIG = str(Path(__file__).resolve().parents[1] / "config" / "params.yaml")
N = 30
TIME_SCALE = 6.0  # 30 slots of 1 s take 5 s of wall time: room to kill and restart the planner


def test_planner_and_three_agent_processes_survive_a_planner_restart(watcher, procs):
    params = load_params(CONFIG, {"num_slots": N})
    plan = solve(params)
    w = watcher
    common = ["--params-file", CONFIG, "-p", f"num_slots:={N}"]
    agents = [procs("agent", *common, "-p", f"uav_id:={k}", "-p", f"time_scale:={TIME_SCALE}",
                    "-r", f"__node:=agent{k}") for k in range(3)]
    # Discovery of a new process can take a Fast DDS announcement period (~3 s): the agents
    # must be matched before the plan starts their slots, or their first rates are lost.
    assert w.spin_until(w.agents_matched, 20.0), "agents not discovered"
    planner = procs("planner", *common)

    assert w.spin_until(lambda: w.formations and w.powers, 30.0), "no /formation"
    poses = np.array([[p.position.x, p.position.z] for p in w.formations[0].poses])
    assert np.allclose(poses, plan.formation, rtol=1e-6, atol=1e-6)
    assert np.allclose(np.reshape(w.powers[0].data, (3, N)), plan.p_com_w, rtol=1e-6)

    # The planner dies mid-mission; the agents fly on, and keep flying after its restart.
    assert w.spin_until(lambda: all(len(r) >= 3 for r in w.rates.values()), 30.0), w.rates
    planner.send_signal(signal.SIGKILL)
    planner.wait(10)
    at_kill = {k: len(r) for k, r in w.rates.items()}
    assert w.spin_until(lambda: all(len(w.rates[k]) > at_kill[k] + 1 for k in range(3)), 10.0)
    planner = procs("planner", *common)
    assert w.spin_until(lambda: len(w.formations) >= 2, 30.0), "restarted planner is silent"
    again = np.array([[p.position.x, p.position.z] for p in w.formations[-1].poses])
    assert np.allclose(again, poses)

    assert w.spin_until(lambda: all(len(r) >= N for r in w.rates.values()), 30.0), \
        {k: len(r) for k, r in w.rates.items()}
    w.spin_until(lambda: False, 0.5)
    tol = rate_tolerance_bps(params.rate_min_bps)
    d = model.distance_to_station(plan.formation[:, :1], params.y_track[None, :],
                                  plan.formation[:, 1:], params.ground_station)
    expected = model.fdma_rate(plan.p_com_w, d, params.comm_bandwidth_hz, params.beta_c)
    for k in range(3):
        assert len(w.rates[k]) == N  # one rate per slot: the slot clock never restarted
        assert np.allclose(w.rates[k], expected[k], rtol=1e-9)
        assert min(w.rates[k]) >= params.rate_min_bps[k] - tol
    stop_cleanly([planner, *agents])


def test_bad_params_file_stops_the_planner_with_code_2_and_publishes_nothing(
        watcher, procs, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text('"/**":\n  ros__parameters:\n    num_slots: 0\n    scheme: nope\n'
                   "    z_min_m: 150.0\n")
    w = watcher
    planner = procs("planner", "--params-file", str(bad))
    out, _ = planner.communicate(timeout=30)
    assert planner.returncode == 2, out
    errors = [line for line in out.splitlines() if "[ERROR]" in line]
    assert len(errors) == 3, out
    for name in ("num_slots", "scheme", "z_min_m"):
        assert any(f"]: {name}: " in line for line in errors), out
    w.spin_until(lambda: False, 1.0)
    assert (w.formations, w.powers, w.diagnostics) == ([], [], [])


@pytest.mark.parametrize("args,name", [(["-p", f"uav_id:={MAX_UAVS}"], "uav_id"),  # no swarm's
                                       (["-p", "uav_id:=5"], "uav_id"),  # num_uavs is 3
                                       (["-p", "max_speed_mps:=2.0"], "max_speed_mps")])
def test_bad_agent_parameter_exits_2(procs, args, name):
    agent = procs("agent", *args)
    out, _ = agent.communicate(timeout=30)
    assert agent.returncode == 2, out
    assert f"]: {name}: " in out


def test_a_node_prints_its_stacks_on_the_dump_signal_and_still_stops_cleanly(watcher, procs):
    """STACK_DUMP_SIGNAL, which stop_nodes sends before SIGKILL, makes a spinning node print
    every thread's stack (where it hung, had it hung) without stopping it; Ctrl-C then stops
    it with code 0 as ever."""
    from uav_insar_planner.exit_codes import STACK_DUMP_SIGNAL

    agent = procs("agent", "--params-file", CONFIG, "-p", "uav_id:=1", "-r", "__node:=agent1")

    # A pose comes only from the spinning node's timer: a publisher alone is matched while
    # the node is still in its constructor, where the dump shows no spin (failed in CI).
    assert watcher.spin_until(lambda: watcher.poses[1], 20.0), "agent publishes no pose"
    agent.send_signal(STACK_DUMP_SIGNAL)
    watcher.spin_until(lambda: False, 1.0)
    assert agent.poll() is None  # alive: the dump does not stop it
    out, = stop_cleanly([agent])
    assert "most recent call first" in out and "in spin" in out, out[-2000:]
