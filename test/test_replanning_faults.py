"""Replanning on the faults other than a killed agent: a vehicle's MAVLink heartbeat stops
(fault injected with `SimVehicle.set_radio(False)`: its radio drops all traffic), and a closed
loop that saturates on a seeded deep fade (the simulator's link, not a fake). Real rclpy nodes
and real MAVLink bytes over loopback UDP."""
from __future__ import annotations

import numpy as np
import pytest
from clean_stop import stop_cleanly
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.parameter import Parameter

from uav_insar_planner import load_params, solve
from uav_insar_planner.replanning.triggers import SATURATED_MISSES
from uav_insar_planner.ros.planner import PlannerNode
from uav_insar_planner.ros.swarm_watch import SWARM_STATUS_NAME
from uav_insar_sim.agent_node import AgentNode
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(90)
SYSIDS = (2, 3, 4)


def swarm(w):
    return [s for m in w.diagnostics for s in m.status if s.name == SWARM_STATUS_NAME]


def bridge_links(w) -> dict[str, str]:
    last = {}
    for m in w.diagnostics:
        for s in m.status:
            if s.name.startswith("mavlink_bridge: uav"):
                last[s.name] = {kv.key: kv.value for kv in s.values}.get("link")
    return last


def test_bridge_reports_the_master_lost_and_commands_loiter_to_the_others(watcher, procs):
    w = watcher
    vehicles = [SimVehicle(s, "udpin:127.0.0.1:0", "ardupilot", start_ned=(0.0, 3.0 * k, -40.0),
                           max_speed=20.0, max_accel=10.0, airborne=True)
                for k, s in enumerate(SYSIDS)]
    for v in vehicles:
        v.start()
    ports = ", ".join(f"'udpout:127.0.0.1:{v.port}'" for v in vehicles)
    try:
        bridge = procs("mavlink_bridge", "-p", f"connections:=[{ports}]",
                       "-p", "target_sysids:=[2, 3, 4]", "-p", "heartbeat_timeout_s:=1.0")
        planner = procs("planner", "-p", "num_slots:=20")
        assert w.spin_until(lambda: w.formations and set(bridge_links(w).values()) == {"linked"}
                            and len(bridge_links(w)) == 3, 30.0, [bridge, planner])
        assert all(v.mode == "GUIDED" for v in vehicles)
        vehicles[0].set_radio(False)  # the fault: uav0's vehicle goes silent
        assert w.spin_until(lambda: len(w.formations) >= 2, 8.0, [bridge, planner])
        assert np.isnan([[p.position.x, p.position.z] for p in w.formations[-1].poses]).all()
        assert w.spin_until(w.plan_failed, 3.0)
        message = w.plan_status().message
        assert message.startswith("mission cannot continue: master uav0 lost at slot 0 "
                                  "(MAVLink bridge: lost: no heartbeat for "), message
        # Every vehicle still linked is put in LOITER (ArduCopter custom_mode 5).
        assert w.spin_until(lambda: vehicles[1].mode == vehicles[2].mode == "LOITER", 8.0), \
            [v.mode for v in vehicles]
        assert vehicles[0].mode == "GUIDED"  # it never heard the order
        assert swarm(w)[-1].level == DiagnosticStatus.ERROR
        out = stop_cleanly([bridge, planner])[0]
        assert "commanding LOITER to every vehicle" in out, out
    finally:
        for v in vehicles:
            v.stop()


# Seeded deep fade on uav1 (6 dB log-normal shadowing over 40 m, seed 15): without ROS its
# closed loop misses R_min at P_max from slot 7 on (replanning/plans.py's own Mission run shows it).
N = 20
FADE = {"shadowing_std_db": 6.0, "shadowing_corr_m": 40.0, "fading_seed": 15}


def test_saturated_closed_loop_warns_then_replans_its_power(watcher):
    params = load_params(overrides={"num_slots": N})
    plan = solve(params)
    ctx = watcher.node.context
    scenario = [Parameter("num_slots", value=N)]
    planner = PlannerNode(context=ctx, parameter_overrides=scenario)
    agent = AgentNode("agent1", context=ctx, parameter_overrides=scenario + [
        Parameter("uav_id", value=1), Parameter("time_scale", value=10.0),
        Parameter("offloading", value="closed")] + [
        Parameter(n, value=v) for n, v in FADE.items()])
    assert not agent.problems, agent.problems
    w = watcher
    for node in (planner, agent):
        w.add_node(node)
    try:
        assert w.spin_until(lambda: len(w.powers) >= 2, 30.0), w.offloads[1]
        w.spin_until(lambda: len(w.offloads[1]) >= N, 10.0)
    finally:
        planner.stop()
        for node in (planner, agent):
            node.destroy_node()
    warn = [s for s in swarm(w) if s.level == DiagnosticStatus.WARN]
    assert warn, [s.message for s in swarm(w)]
    text = warn[0].message
    assert text.startswith(f"uav1 closed loop saturated: R_min missed {SATURATED_MISSES} "
                           "slots in a row (slots "), text
    first, last = (int(v) for v in text.split("(slots ")[1].split(")")[0].split("-"))
    assert last - first == SATURATED_MISSES - 1
    # The missed slots are what the agent reported: below R_min, at P_max.
    for n in range(first, last + 1):
        slot, power_w, *_ = w.offloads[1][n]
        assert slot == n and power_w >= params.p_max_w * (1 - 1e-3)
        assert w.rates[1][n] < params.rate_min_bps[1]
    # Then a power re-plan, formation unchanged, uav1's slots from last + 1 only, within
    # P_max and the energy left then (the fade goes on, so more may follow).
    replans = [s for m in w.diagnostics for s in m.status
               if s.name == "planner: plan" and "re-planned" in s.message]
    status = replans[0]
    assert f"power of uav1 re-planned from slot {last + 1}" in status.message, status.message
    assert status.level == DiagnosticStatus.OK
    before = np.reshape(w.powers[0].data, (3, N))
    after = np.reshape(w.powers[1].data, (3, N))
    assert np.allclose(before, plan.p_com_w)
    poses = [[(p.position.x, p.position.z) for p in m.poses] for m in w.formations]
    assert np.allclose(poses[-1], poses[0], equal_nan=True)
    assert np.array_equal(after[[0, 2]], before[[0, 2]])
    assert np.array_equal(after[1, :last + 1], before[1, :last + 1])
    assert not np.allclose(after[1, last + 1:], before[1, last + 1:])
    left = w.offloads[1][last][3]
    assert after[1, last + 1:].sum() * params.slot_duration_s <= left * (1 + 1e-9)
    assert after[1].max() <= params.p_max_w
