"""Launch-free bring-up in one process: planner and three agents on one executor (real rclpy
on Fast DDS, real topics), watched by the suite's TopicWatcher."""
from __future__ import annotations

import math

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from uav_insar_planner import load_params, model, solve
from uav_insar_planner.evaluate import rate_tolerance_bps
from uav_insar_planner.ros.planner import PlannerNode
from uav_insar_sim.agent_node import AgentNode

N = 6
TIME_SCALE = 40.0
SCENARIO = {"num_slots": N}


class Bringup:
    """Planner + agents in this process, spun on the test's TopicWatcher executor; the
    watcher's recordings are this object's."""

    def __init__(self, watcher, noise_std: float = 0.0, agents: bool = True,
                 scenario: dict | None = None):
        ctx = watcher.node.context
        overrides = [Parameter(k, value=v) for k, v in (scenario or SCENARIO).items()]
        self.planner = PlannerNode(context=ctx, parameter_overrides=overrides)
        self.agents = [AgentNode(f"agent{k}", context=ctx, parameter_overrides=overrides + [
            Parameter("uav_id", value=k), Parameter("time_scale", value=TIME_SCALE),
            Parameter("position_noise_std_m", value=noise_std),
            Parameter("noise_seed", value=3)]) for k in range(3)] if agents else []
        for node in [self.planner, *self.agents]:
            watcher.add_node(node)
        self.watcher = watcher.node
        self.formations, self.powers = watcher.formations, watcher.powers
        self.diagnostics, self.rates = watcher.diagnostics, watcher.rates
        self.spin_until = watcher.spin_until

    def close(self) -> None:
        self.planner.stop()
        for node in [self.planner, *self.agents]:
            node.destroy_node()


@pytest.fixture
def bringup(watcher):
    made = []

    def make(**kw):
        made.append(Bringup(watcher, **kw))
        return made[-1]

    yield make
    for b in made:
        b.close()


def planned_rates(plan, params):
    """R_k,n at the planned q_k[n] with the planned P_com[k][n] (what a perfect agent gets)."""
    x, z = plan.formation[:, :1], plan.formation[:, 1:]
    d = model.distance_to_station(x, params.y_track[None, :], z, params.ground_station)
    return model.fdma_rate(plan.p_com_w, d, params.comm_bandwidth_hz, params.beta_c)


def statuses(diag_array):
    return {s.name: s for s in diag_array.status}


def test_planner_and_agents_fly_the_solved_plan(bringup):
    params = load_params(overrides=SCENARIO)
    plan = solve(params)
    b = bringup()
    assert b.spin_until(lambda: b.formations and b.powers, 30.0), "no /formation"
    msg = b.formations[0]
    assert msg.header.frame_id == "insar_track"
    got = np.array([[p.position.x, p.position.y, p.position.z] for p in msg.poses])
    assert np.allclose(got[:, [0, 2]], plan.formation, rtol=1e-6, atol=1e-6)
    assert not got[:, 1].any() and all(p.orientation.w == 1.0 for p in msg.poses)
    power = b.powers[0]
    stamp = msg.header.stamp
    identity = f"plan /planner {stamp.sec}.{stamp.nanosec:09d}"  # the same plan on both
    assert [(d.label, d.size, d.stride) for d in power.layout.dim] == [
        ("uav", 3, 3 * N), ("slot", N, N), (identity, 1, 1)]
    assert np.allclose(np.reshape(power.data, (3, N)), plan.p_com_w, rtol=1e-6)

    assert b.spin_until(lambda: all(len(r) >= N for r in b.rates.values()), 30.0), b.rates
    b.spin_until(lambda: False, 0.3)  # nothing beyond the last slot
    expected = planned_rates(plan, params)
    tol = rate_tolerance_bps(params.rate_min_bps)
    for k in range(3):
        assert len(b.rates[k]) == N
        # Noise off: the agent sits on its planned position, so it gets the planned rate,
        # which the plan sizes to meet R_min (within the checker's C10 tolerance).
        assert np.allclose(b.rates[k], expected[k], rtol=1e-9)
        assert min(b.rates[k]) >= params.rate_min_bps[k] - tol

    b.spin_until(lambda: False, 1.2)  # one more diagnostics period after the mission
    last = statuses(b.diagnostics[-1])
    assert last["planner: plan"].level == DiagnosticStatus.OK
    keys = {kv.key for kv in last["planner: plan"].values}
    assert {"sigma_h_m", "sigma_h_bound_m", "b_perp_m.uav1", "h_amb_m.uav2", "coherence.uav1",
            "solve_time_s", "iterations", "scheme"} <= keys
    for k in range(3):
        uav = last[f"planner: uav{k}"]
        values = {kv.key: kv.value for kv in uav.values}
        assert uav.level == DiagnosticStatus.OK, uav.message
        assert float(values["position_error_m"]) < 1e-9
        assert values["slots_reported"] == str(N)


def test_position_noise_shrinks_the_margin_and_warns(bringup):
    scenario = {**SCENARIO, "rate_margin": 0.0}
    params = load_params(overrides=scenario)
    expected = planned_rates(solve(params), params)
    b = bringup(noise_std=3.0, scenario=scenario)
    assert b.spin_until(lambda: all(len(r) >= N for r in b.rates.values()), 40.0), b.rates
    # No rate margin (the paper's C10): the plan's rates are tight (R_min exactly at the
    # planned position), so a disturbed position misses R_min in roughly every other slot: the
    # worst margin drops well below the noise-free one, which the first test pins at >= -tol.
    margins = np.concatenate([np.array(b.rates[k]) - params.rate_min_bps[k] for k in range(3)])
    assert margins.min() < -1e4
    assert not np.allclose(np.concatenate([b.rates[k] for k in range(3)]), expected.ravel())
    warn = DiagnosticStatus.WARN
    assert b.spin_until(lambda: any(s.level == warn for d in b.diagnostics for s in d.status),
                        5.0), "no WARN for a UAV missing R_min"
    errors = [float(kv.value) for d in b.diagnostics for s in d.status for kv in s.values
              if kv.key == "position_error_m"]
    assert max(errors) > 0.1


def test_runtime_parameter_set_replans_or_is_refused(bringup):
    b = bringup(agents=False)
    assert b.spin_until(lambda: b.formations, 30.0)
    planner = b.planner
    refused = planner.set_parameters([Parameter("scheme", value="nope")])[0]
    assert not refused.successful and "scheme" in refused.reason
    refused = planner.set_parameters([Parameter("z_min_m", value=150.0)])[0]
    assert not refused.successful and "z_min_m" in refused.reason
    assert planner.get_parameter("scheme").value == "proposed"

    assert planner.set_parameters([Parameter("scheme", value="single-baseline")])[0].successful
    assert b.spin_until(lambda: len(b.formations) >= 2 and len(b.powers) >= 2, 30.0), \
        "no replan after the set"
    u2 = b.formations[-1].poses[2].position
    assert math.isnan(u2.x) and math.isnan(u2.z)
    assert not any(np.reshape(b.powers[-1].data, (3, N))[2])
    assert statuses(b.diagnostics[-1])["planner: plan"].level == DiagnosticStatus.OK


def test_replan_service_answers_at_once_and_republishes(bringup):
    b = bringup(agents=False)
    assert b.spin_until(lambda: b.formations, 30.0)
    trigger = Trigger
    client = b.watcher.create_client(trigger, "/planner/replan")
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(trigger.Request())
    assert b.spin_until(future.done, 10.0)
    assert future.result().success and "solving" in future.result().message
    assert b.spin_until(lambda: len(b.formations) >= 2, 30.0)
    assert b.formations[-1].header.stamp != b.formations[0].header.stamp


def test_infeasible_plan_is_an_error_and_not_published(bringup):
    # 5 Gbit/s on a 1 GHz channel needs far more than P_com^max at any distance: C9 and C10
    # cannot hold together.
    b = bringup(agents=False, scenario={**SCENARIO, "rate_min_mbps": [5000.0, 16.95, 1.0]})
    assert b.spin_until(lambda: b.diagnostics, 30.0)
    plan_status = statuses(b.diagnostics[0])["planner: plan"]
    assert plan_status.level == DiagnosticStatus.ERROR and "not published" in plan_status.message
    assert "blocked by C9, C10" in plan_status.message
    b.spin_until(lambda: False, 0.5)
    assert b.formations == [] and b.powers == []


def test_planner_takes_nav_error_and_reports_the_worst_case(bringup):
    """nav_error_m is a scenario parameter, so the planner takes it: it flies the robust plan
    and puts the certified worst case on /diagnostics; a back end that plans nominal positions
    refuses it at the set, naming the field."""
    scenario = {**SCENARIO, "nav_error_m": 0.25}
    plan = solve(load_params(overrides=scenario))
    b = bringup(agents=False, scenario=scenario)
    assert b.spin_until(lambda: b.formations and any(
        "planner: plan" in statuses(d) for d in b.diagnostics), 30.0)
    got = np.array([[p.position.x, p.position.z] for p in b.formations[0].poses])
    assert np.allclose(got, plan.formation, rtol=1e-6, atol=1e-6)
    status = next(statuses(d)["planner: plan"] for d in b.diagnostics
                  if "planner: plan" in statuses(d))
    values = {kv.key: kv.value for kv in status.values}
    assert status.level == DiagnosticStatus.OK and "worst case" in status.message
    assert float(values["nav_error_m"]) == 0.25
    assert float(values["sigma_h_worst_m"]) == pytest.approx(plan.sigma_h_worst_m, rel=1e-5)
    assert float(values["sigma_h_worst_m"]) > float(values["sigma_h_m"])
    refused = b.planner.set_parameters([Parameter("solver", value="paper-ao")])[0]
    assert not refused.successful and "nav_error_m" in refused.reason
