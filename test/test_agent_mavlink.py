"""Agents in MAVLink mode, flown by the bridge: planner -> /formation -> mavlink_bridge ->
MAVLink over loopback UDP -> the vehicle each agent embeds -> the agent's /uavK/pose and
/uavK/achieved_rate. Real nodes on one executor (our runtime over real rclpy), real sockets."""
from __future__ import annotations

import math

import process_group
import pytest
from rclpy.parameter import Parameter

from uav_insar_planner import load_params, model, solve
from uav_insar_planner.ros.mavlink_bridge import MavlinkBridgeNode
from uav_insar_planner.ros.planner import PlannerNode
from uav_insar_sim.agent_node import AgentNode
from uav_insar_sim.observed_mission import ObservedMission, interpolate

pytestmark = pytest.mark.timeout(60)
SCENARIO = {"num_slots": 4, "slot_duration_s": 0.5}


def test_slots_start_where_the_vehicle_crosses_their_lines():
    params = load_params(overrides=SCENARIO)
    mission = ObservedMission(1, params)
    assert mission.observe((0.0, -5.0, 10.0)) == [] and mission.phase == "wait"
    mission.set_plan((-30.0, 50.0), [1.0, 2.0, 3.0, 4.0], y_start=0.0)
    step = params.speed * params.slot_duration_s  # 2.15 m between slot lines
    assert mission.observe((-30.0, -0.5, 50.0)) == [] and mission.phase == "transit"
    # one observation past two lines: both slots, each at its own crossing point
    started = mission.observe((-29.0, step + 0.5, 52.0))
    assert [s.slot for s in started] == [0, 1] and mission.phase == "track"
    assert started[1].position == pytest.approx(
        interpolate((-30.0, -0.5, 50.0), (-29.0, step + 0.5, 52.0), step))
    expected = model.fdma_rate(2.0, model.distance_to_station(
        *started[1].position, params.ground_station), params.comm_bandwidth_hz, params.beta_c)
    assert started[1].rate_bps == pytest.approx(float(expected))
    assert mission.observe((-29.0, step, 52.0)) == []  # backwards: nothing
    assert [s.slot for s in mission.observe((-29.0, 4 * step, 52.0))] == [2, 3]
    assert mission.phase == "done"


@pytest.mark.parametrize("bearing_deg, origin", [(0.0, [0.0, 0.0, 0.0]),
                                                 (90.0, [5.0, -3.0, 0.0])])
def test_agents_in_mavlink_mode_fly_the_plan_through_the_bridge(watcher, bearing_deg, origin):
    """Also with a rotated, offset track frame, given alike to the bridge and the agents."""
    ros_context = watcher.node.context
    params = load_params(overrides=SCENARIO)
    plan = solve(params)
    frame = [Parameter("track_bearing_deg", value=bearing_deg),
             Parameter("origin_ned_m", value=origin)]
    scenario = [Parameter(k, value=v) for k, v in SCENARIO.items()]
    planner = PlannerNode(context=ros_context, parameter_overrides=scenario)
    agents = [AgentNode(f"agent{k}", context=ros_context, parameter_overrides=scenario + [
        Parameter("uav_id", value=k), Parameter("mavlink_listen", value="udpin:127.0.0.1:0"),
        Parameter("max_speed_mps", value=20.0), Parameter("max_accel_mps2", value=10.0),
        *frame]) for k in range(3)]
    assert not any(a.problems for a in agents), [a.problems for a in agents]
    ports = [a.vehicle.port for a in agents]
    bridge = MavlinkBridgeNode(context=ros_context, parameter_overrides=[
        Parameter("connections", value=[f"udpout:127.0.0.1:{p}" for p in ports]),
        Parameter("capture_radius_m", value=0.2),
        Parameter("velocity_feedforward", value=True), *frame])
    assert not bridge.problems, bridge.problems
    nodes = [planner, bridge, *agents]
    for node in nodes:
        watcher.add_node(node)
    formation, rates = watcher.formations, watcher.rates

    n = params.num_slots
    try:
        assert watcher.spin_until(lambda: formation, 30.0), "no /formation"
        assert watcher.spin_until(lambda: all(len(rates[k]) >= n for k in range(3)),
                                  30.0), rates
        watcher.spin_until(lambda: False, 0.5)
    finally:
        bridge.stop()
        planner.stop()
        for node in nodes:
            node.destroy_node()
    planned = model.fdma_rate(plan.p_com_w, model.distance_to_station(
        plan.formation[:, :1], params.y_track[None, :], plan.formation[:, 1:],
        params.ground_station), params.comm_bandwidth_hz, params.beta_c)
    for k in range(3):
        x_k, z_k = plan.formation[k]
        last = watcher.poses[k][-1].pose.position
        # the embedded vehicle, flown by the bridge, holds the planned across-track position
        assert math.hypot(last.x - x_k, last.z - z_k) < 0.5, (k, last)
        assert last.y > (n - 0.5) * params.speed * params.slot_duration_s  # flew the slots
        assert len(rates[k]) == n  # one rate per slot, no more
        # rates from where the vehicle really was: close to the planned ones
        assert rates[k] == pytest.approx(list(planned[k]), rel=0.005), k


def test_a_bad_mavlink_listen_is_one_problem_line(ros_context):
    agent = AgentNode("agent", context=ros_context, parameter_overrides=[
        Parameter("mavlink_listen", value="nowhere")])
    try:
        assert len(agent.problems) == 1 and agent.problems[0].startswith("mavlink_listen:")
        assert agent.vehicle is None
    finally:
        agent.destroy_node()


def test_an_agent_whose_embedded_vehicle_dies_exits_1(ros_domain):
    """FAULT INJECTION (test/fault_injection.py): the embedded vehicle's link raises 2 s
    after start, killing its thread; the agent must say so and exit 1, not fly on as a
    zombie publishing a frozen pose."""
    import os
    import sys

    fault = os.path.join(os.path.dirname(__file__), "fault_injection.py")
    out = process_group.run([sys.executable, fault, "2.0", "uav_insar_sim.agent_node",
                          "--ros-args", "-p", "mavlink_listen:=udpin:127.0.0.1:0"],
                         capture_output=True, text=True, timeout=40)
    assert out.returncode == 1, out
    errors = [line for line in (out.stdout + out.stderr).splitlines() if "ERROR" in line]
    assert len(errors) == 1 and "embedded MAVLink vehicle died" in errors[0], out
