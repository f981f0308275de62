"""Drift under wind, as the operator sees it on /diagnostics: planner and three agents
in-process on a real executor, uav1 alone in a steady 5 m/s across-track wind away from the
ground station (a real seeded disturbance of the simulator's kinematics, nothing faked)."""
from __future__ import annotations

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.parameter import Parameter

from uav_insar_planner import load_params
from uav_insar_planner.evaluate import rate_tolerance_bps
from uav_insar_planner.ros.planner import PlannerNode
from uav_insar_sim.agent_node import AgentNode

N = 8
# No rate margin (the paper's C10), so the open loop's drift shows in the verdict: the default
# 5 % margin carries uav1 through this drift (17.3 of 16.95 Mbit/s, measured)
SCENARIO = {"num_slots": N, "rate_margin": 0.0}
WIND = [-5.0, 0.0, 0.0]  # pushes uav1 away from the ground station (Table I)


def uav_statuses(watcher, k: int) -> list[DiagnosticStatus]:
    return [s for m in watcher.diagnostics for s in m.status if s.name == f"planner: uav{k}"]


def value(status: DiagnosticStatus, key: str) -> float:
    return float(next((v.value for v in status.values if v.key == key), "nan"))


def fly(watcher, offloading: str) -> None:
    """One mission; returns when every agent reported all N rates and the planner's
    per-UAV statuses have seen the last of them."""
    ctx = watcher.node.context
    scenario = [Parameter(k, value=v) for k, v in SCENARIO.items()]
    planner = PlannerNode(context=ctx, parameter_overrides=scenario)
    agents = [AgentNode(f"agent{k}", context=ctx, parameter_overrides=scenario + [
        Parameter("uav_id", value=k), Parameter("time_scale", value=40.0),
        Parameter("offloading", value=offloading)] + (
        [Parameter("wind_mps", value=WIND)] if k == 1 else [])) for k in range(3)]
    for agent in agents:
        assert not agent.problems, agent.problems
    for node in [planner, *agents]:
        watcher.add_node(node)
    try:
        done = lambda: all(len(watcher.rates[k]) >= N for k in range(3)) and all(  # noqa: E731
            uav_statuses(watcher, k) and value(uav_statuses(watcher, k)[-1], "slots_reported")
            >= N for k in range(3))
        assert watcher.spin_until(done, 40.0), [len(watcher.rates[k]) for k in range(3)]
    finally:
        planner.stop()
        for node in [planner, *agents]:
            node.destroy_node()


@pytest.mark.parametrize("offloading", ["open", "closed"])
def test_a_drifting_uav_shows_its_position_error_and_its_rate_verdict(watcher, offloading):
    params = load_params(overrides=SCENARIO)
    tol = rate_tolerance_bps(params.rate_min_bps)
    fly(watcher, offloading)
    last = {k: uav_statuses(watcher, k)[-1] for k in range(3)}
    # The wind pushes uav1 metres downwind of its target; the others fly on their targets.
    assert value(last[1], "position_error_m") > 1.0, last[1]
    for k in (0, 2):
        assert value(last[k], "position_error_m") < 0.05, last[k]
        assert last[k].level == DiagnosticStatus.OK, last[k].message
    # The verdict follows the rate the drifted UAV achieved in its last slot.
    missed = watcher.rates[1][-1] < params.rate_min_bps[1] - tol
    assert (last[1].level == DiagnosticStatus.WARN) == missed, (last[1].message,
                                                                 watcher.rates[1])
    if offloading == "open":
        # The planned power no longer reaches R_min from where the wind put it.
        assert missed and last[1].level == DiagnosticStatus.WARN, watcher.rates[1]
    else:
        # Closed loop measures the drifted position and spends what the link needs there.
        assert not missed and last[1].level == DiagnosticStatus.OK, last[1].message
        assert all(r >= params.rate_min_bps[1] - tol for r in watcher.rates[1][2:])
