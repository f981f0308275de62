"""Agents in MAVLink mode, flown by the bridge: planner -> /formation -> mavlink_bridge ->
MAVLink over loopback UDP -> the vehicle each agent embeds -> the agent's /uavK/pose and
/uavK/achieved_rate. Real nodes on one executor (our runtime over real rclpy), real sockets."""
from __future__ import annotations

import math

import numpy as np
import process_group
import pytest
from rclpy.parameter import Parameter

from uav_insar_planner import load_params, model, solve
from uav_insar_planner.ros.mavlink_bridge import MavlinkBridgeNode
from uav_insar_planner.ros.planner import PlannerNode
from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_planner.track.speed_profile import RAMP_MPS2
from uav_insar_sim.agent_node import AgentNode
from uav_insar_sim.observed_mission import ObservedMission, interpolate
from uav_insar_sim.slots import Phase

pytestmark = pytest.mark.timeout(60)
SCENARIO = {"num_slots": 4, "slot_duration_s": 0.5}


def test_slots_start_where_the_vehicle_crosses_their_lines():
    params = load_params(overrides=SCENARIO)
    mission = ObservedMission(1, params)
    assert mission.observe((0.0, -5.0, 10.0), 0.0) == [] and mission.phase == Phase.WAIT
    mission.set_plan((-30.0, 50.0), [1.0, 2.0, 3.0, 4.0], y_start=0.0)
    mission.set_pass_start(PassClock(1.0, params.speed))
    step = params.speed * params.slot_duration_s  # 2.15 m between slot lines
    assert mission.observe((-30.0, -0.5, 50.0), 1.0) == [] and mission.phase == Phase.TRANSIT
    # one observation past two lines: both slots, each at its own crossing point
    started = mission.observe((-29.0, step + 0.5, 52.0), 1.1)
    assert [s.slot for s in started] == [0, 1] and mission.phase == Phase.TRACK
    assert started[1].position == pytest.approx(
        interpolate((-30.0, -0.5, 50.0), (-29.0, step + 0.5, 52.0), step))
    expected = model.fdma_rate(2.0, model.distance_to_station(
        *started[1].position, params.ground_station), params.comm_bandwidth_hz, params.beta_c)
    assert started[1].rate_bps == pytest.approx(float(expected))
    assert mission.observe((-29.0, step, 52.0), 1.2) == []  # backwards: nothing
    assert [s.slot for s in mission.observe((-29.0, 4 * step, 52.0), 1.3)] == [2, 3]
    assert mission.phase == Phase.DONE


def _mission(pass_start_s: float | None = 10.0) -> ObservedMission:
    mission = ObservedMission(1, load_params(overrides=SCENARIO))
    mission.set_plan((-30.0, 50.0), [1.0, 2.0, 3.0, 4.0], y_start=0.0)
    if pass_start_s is not None:
        mission.set_pass_start(PassClock(pass_start_s, mission.params.speed))
    return mission


@pytest.mark.parametrize("take_off_y", [-20.0, 0.0, 15.0])
def test_no_slot_before_the_pass_start_wherever_the_uav_took_off(take_off_y):
    """Behind, beside or ahead of the start: the UAV climbs, crosses the track forward on its
    way to its formation point and holds there, jittering about the slot 0 line (a copter in
    wind with GNSS noise), all before the pass start: no slot. Then slot 0 at the start."""
    mission = _mission(pass_start_s=10.0)
    rng = np.random.default_rng(int(take_off_y) + 100)
    t = 0.0
    # transit: from the take-off point to the formation point, through y = 0 and beyond
    for y in np.linspace(take_off_y, 3.0, 20).tolist() + np.linspace(3.0, 0.0, 10).tolist():
        assert mission.observe((-30.0, y, 50.0), t) == [], (take_off_y, y)
        t += 0.1
    # holding the line: +-0.3 m of jitter either side of y = 0 for 5 s
    while t < 9.95:
        assert mission.observe((-30.0, float(rng.normal(0.0, 0.15)), 50.0), t) == []
        t += 0.1
    assert mission.samples == [] and mission.phase == Phase.TRANSIT
    # the pass starts: the first position at or past the line starts slot 0
    held = (-30.0, -0.12, 50.0)
    assert mission.observe(held, 10.0) == []  # at the start, still behind the line
    first = mission.observe((-30.0, 0.31, 50.0), 10.1)
    assert [s.slot for s in first] == [0]
    assert first[0].position == pytest.approx(interpolate(held, (-30.0, 0.31, 50.0), 0.0))
    # when it crossed the line, interpolated between the two readings
    assert mission.slot_times_s == pytest.approx([10.0 + 0.1 * 0.12 / 0.43])


def test_a_uav_holding_just_ahead_of_the_line_starts_slot_0_at_the_start_where_it_is():
    mission = _mission(pass_start_s=10.0)
    assert mission.observe((-30.0, 0.2, 50.0), 9.9) == []
    started = mission.observe((-30.0, 0.25, 50.1), 10.05)
    assert [s.slot for s in started] == [0] and started[0].position == (-30.0, 0.25, 50.1)
    # jitter back behind the line changes nothing; slot 1 waits for its own line
    assert mission.observe((-30.0, -0.1, 50.0), 10.15) == []
    assert mission.observe((-30.0, 2.0, 50.0), 10.5) == []
    assert [s.slot for s in mission.observe((-30.0, 2.2, 50.0), 10.6)] == [1]


def test_no_pass_start_no_slot_and_the_lag_is_told():
    mission = _mission(pass_start_s=None)
    for i, y in enumerate(np.linspace(-10.0, 20.0, 31)):
        assert mission.observe((-30.0, float(y), 50.0), 0.1 * i) == []
    assert mission.lag(100.0) is None  # no start: nothing is late, the agent says so itself
    mission = _mission(pass_start_s=10.0)
    mission.observe((-30.0, -4.0, 50.0), 11.0)
    assert mission.lag(9.0) is None  # before the start
    n, late, to_go = mission.lag(13.0)
    assert (n, late, to_go) == (0, pytest.approx(3.0), pytest.approx(4.0))
    assert mission.observe((-30.0, 0.0, 50.0), 13.1)[0].slot == 0
    step = mission.params.speed * mission.params.slot_duration_s
    # slot 1 was due when the target, ramping up from the hover at 10 s, crossed its line
    due = 10.0 + math.sqrt(2.0 * step / RAMP_MPS2)
    assert mission.line_time(1) == pytest.approx(due)
    assert mission.lag(13.2) == (1, pytest.approx(13.2 - due), pytest.approx(step))
    mission.observe((-30.0, step - 1.0, 50.0), 14.0)
    assert mission.lag(14.0) == (1, pytest.approx(14.0 - due), pytest.approx(1.0))
    mission.observe((-30.0, 4 * step, 50.0), 14.1)
    assert mission.phase == Phase.DONE and mission.lag(20.0) is None


def test_a_new_pass_needs_a_new_start():
    """A re-plan with the same y_start keeps the running pass; another y_start is another
    pass, which starts only at its own pass start."""
    mission = _mission(pass_start_s=10.0)
    mission.set_plan((-31.0, 50.0), [1.0, 2.0, 3.0, 4.0], y_start=0.0)
    assert mission.pass_start_s == 10.0
    mission.set_plan((-31.0, 50.0), [1.0, 2.0, 3.0, 4.0], y_start=5.0)
    assert mission.pass_start_s is None
    mission.observe((-31.0, 4.0, 50.0), 20.0)
    assert mission.observe((-31.0, 6.0, 50.0), 20.1) == []


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


def test_a_pass_start_heard_late_starts_each_slot_where_its_line_was_crossed():
    """A lossy radio delivers formation/start 1.2 s after its instant: the UAV is already
    2.5 lines down the track. Its slots still start where it crossed each line, from the
    positions read meanwhile, not all at the one position it has when the start arrives."""
    mission = _mission(pass_start_s=None)
    step = mission.params.speed * mission.params.slot_duration_s
    v = mission.params.speed
    t, y = 9.0, -0.2
    while t < 11.25:  # holding until 10 s, then flying the pass at v_y
        y = -0.2 if t < 10.0 else -0.2 + v * (t - 10.0)
        assert mission.observe((-30.0, y, 50.0), t) == []
        t = round(t + 0.1, 6)
    started = mission.set_pass_start(PassClock(10.0, mission.params.speed))
    assert [s.slot for s in started] == [0, 1, 2] and y > 2 * step
    for n, s in enumerate(started):
        assert s.position[1] == pytest.approx(n * step, abs=1e-9)
    # when it crossed each line (between two readings): 0.2 m behind at 10 s, then v_y
    dt = mission.params.slot_duration_s
    assert mission.slot_times_s == pytest.approx([10.0 + 0.2 / v + n * dt for n in range(3)])
    assert [s.slot for s in mission.observe((-30.0, 3 * step + 0.1, 50.0), 11.3)] == [3]
