"""One plan at a time, with real processes on a private domain: the plan identity on both
topics, two planners on one domain, bad plan messages from a test publisher (to an agent and
to the MAVLink bridge), and a planner restarted with an infeasible scenario."""
from __future__ import annotations

import math
import os

import numpy as np
import pytest
from clean_stop import stop_cleanly
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseArray
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from uav_insar_planner import load_params, model, solve
from uav_insar_planner.demo.processes import start_node, stop_node
from uav_insar_planner.published import formation_points
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.plan_msgs import PlanId, encode
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(120)
N = 40
TIME_SCALE = 3.0  # 40 slots of 1 s take ~13 s of wall time: the mission outlasts each test
COMMON = ["-p", f"num_slots:={N}"]
INFEASIBLE = "rate_min_mbps:=[5000.0, 16.95, 1.0]"  # C9 and C10 cannot hold together


def start_agents(procs, uavs=range(3)):
    return [procs("agent", *COMMON, "-p", f"uav_id:={k}", "-p", f"time_scale:={TIME_SCALE}",
                  "-r", f"__node:=agent{k}") for k in uavs]


def diag(w, name, since=0):
    """Every status called `name` on /diagnostics from message `since` on."""
    return [s for m in w.diagnostics[since:] for s in m.status if s.name == name]


def value(status, key):
    return next(v.value for v in status.values if v.key == key)


def planned_rates(plan, params):
    x, z = plan.formation[:, :1], plan.formation[:, 1:]
    d = model.distance_to_station(x, params.y_track[None, :], z, params.ground_station)
    return model.fdma_rate(plan.p_com_w, d, params.comm_bandwidth_hz, params.beta_c)


def test_plan_identity_is_the_same_on_both_topics_and_changes_on_replan(watcher, procs):
    w = watcher
    planner = procs("planner", "-p", "num_slots:=6")
    assert w.spin_until(lambda: w.formations and w.powers, 30.0), "no plan"
    client = w.node.create_client(Trigger, "/planner/replan")
    assert client.wait_for_service(timeout_sec=10.0)
    future = client.call_async(Trigger.Request())
    # (the new plan's topics may overtake the service's answer: other writers, no order)
    assert w.spin_until(lambda: future.done() and len(w.formations) >= 2
                        and len(w.powers) >= 2, 30.0)
    assert future.result().success
    stamps, ids = w.plan_ids()
    assert [i.planner for i in ids] == ["/planner", "/planner"]
    assert stamps == [i.stamp for i in ids]  # formation k and power k: one plan
    assert stamps[1] > stamps[0]
    stop_cleanly([planner])


def test_two_planners_are_reported_and_never_mixed(watcher, procs):
    """proposed (/planner) and fixed-master (/planner2): both report ERROR naming the other,
    the agents hold the first plan; planner2 stops: they fly on with /planner's plan (rates
    of its power at its formation); planner2 again and /planner stops: they take planner2's
    latched plan."""
    w = watcher
    params = load_params(overrides={"num_slots": N})
    proposed = solve(params)
    agents = start_agents(procs)
    assert w.spin_until(w.agents_matched, 20.0), "agents not discovered"
    first = procs("planner", *COMMON)
    assert w.spin_until(lambda: all(w.flown_plans.values()), 30.0), w.flown_plans
    first_id = w.flown_plans[0][0]
    assert all(f == [first_id] for f in w.flown_plans.values())
    since = len(w.diagnostics)

    second = procs("planner", *COMMON, "-p", "scheme:=fixed-master", "-r", "__node:=planner2")
    errors = {"/planner": "second planner /planner2 publishes formation",
              "/planner2": "second planner /planner publishes formation"}

    def both_report():
        said = [s.message for s in diag(w, "planner: formation publishers", since)
                if s.level == DiagnosticStatus.ERROR]
        return all(any(m.startswith(text) for m in said) for text in errors.values())

    assert w.spin_until(both_report, 30.0), [s.message for m in w.diagnostics[since:]
                                             for s in m.status]
    assert w.spin_until(lambda: any(i.planner == "/planner2" for i in w.plan_ids()[1]), 10.0)
    w.spin_until(lambda: False, 2.0)  # the agents had time to take planner2's plan: they hold
    assert all(f == [first_id] for f in w.flown_plans.values()), w.flown_plans

    code = stop_node(second)  # a clean stop: SIGKILL waits out the DDS lease (~20 s)
    assert code == 0, second.stdout.read()[-4000:]
    since = len(w.diagnostics)
    assert w.spin_until(lambda: any(s.level == DiagnosticStatus.OK for s in diag(
        w, "planner: formation publishers", since)), 15.0), "planner still sees planner2"
    assert w.spin_until(lambda: all(len(r) >= 8 for r in w.rates.values()), 30.0)
    assert all(f == [first_id] for f in w.flown_plans.values()), w.flown_plans
    expected = planned_rates(proposed, params)  # open loop, no noise: the plan's own rates
    for k in range(3):
        got = w.rates[k]
        assert np.allclose(got, expected[k][:len(got)], rtol=1e-9), k

    # planner2 again, then the first goes: the agents take planner2's latched plan, whole.
    again = procs("planner", *COMMON, "-p", "scheme:=fixed-master", "-r", "__node:=planner2")
    seen = len(w.powers)
    assert w.spin_until(lambda: len(w.powers) > seen and w.formations, 30.0)
    second_id = w.plan_ids()[1][-1]
    assert second_id.planner == "/planner2"
    w.spin_until(lambda: False, 1.0)
    assert all(f == [first_id] for f in w.flown_plans.values()), w.flown_plans
    code = stop_node(first)
    assert code == 0, first.stdout.read()[-4000:]
    assert w.spin_until(lambda: all(len(f) == 2 for f in w.flown_plans.values()), 15.0), \
        w.flown_plans
    assert all(f == [first_id, second_id.label] for f in w.flown_plans.values())
    for k, text in enumerate(stop_cleanly([again, *agents])[1:]):
        assert f"uav{k}: 2 publishers of formation (/planner, /planner2): keeping " \
               f"{first_id}" in text, text
        assert text.count(f"uav{k}: flying plan") == 2, text
        assert f"uav{k}: flying {second_id}" in text, text


def test_bad_plan_messages_are_dropped_by_an_agent_and_the_bridge(watcher, procs):
    w = watcher
    vehicle = SimVehicle(2, "udpin:127.0.0.1:0", "ardupilot", start_ned=(0.0, 0.0, -10.0),
                         max_speed=20.0, max_accel=10.0, airborne=True)
    vehicle.start()
    bridge = start_node("mavlink_bridge", ["-p", f"connections:=['udpout:127.0.0.1:"
                                           f"{vehicle.port}']", "-p", "target_sysids:=[2]"],
                        dict(os.environ))
    try:
        agent, = start_agents(procs, [0])
        plan = solve(load_params(overrides={"num_slots": N}))
        sec, ns = w.node.get_clock().now().seconds_nanoseconds()
        good_id = PlanId(sec, ns, w.node.get_fully_qualified_name())
        points = formation_points(plan)
        formation, power = encode(points, plan, good_id)
        formation_pub = w.node.create_publisher(PoseArray, "/" + topics.FORMATION,
                                                topics.LATCHED)
        power_pub = w.node.create_publisher(Float64MultiArray, "/" + topics.POWER,
                                            topics.LATCHED)
        formation_pub.publish(formation)
        power_pub.publish(power)
        assert w.spin_until(lambda: w.flown_plans[0], 30.0), "the agent took no plan"
        assert w.flown_plans[0] == [good_id.label]

        def bridge_status():
            found = diag(w, "mavlink_bridge: uav0")
            return found[-1] if found else None

        x0, z0 = (f"{v:.3f}" for v in plan.formation[0])
        assert w.spin_until(lambda: bridge_status() and value(
            bridge_status(), "target_track_m").split()[::2] == [x0, z0], 20.0)

        bad = []
        nan_mix, _ = encode(points, plan, good_id)
        nan_mix.poses[0].position.x = math.nan  # z stays finite
        bad.append((formation_pub, nan_mix))
        huge, _ = encode(points, plan, good_id)
        huge.poses[1].position.z = 1e39
        bad.append((formation_pub, huge))
        _, negative = encode(points, plan, good_id)
        negative.data[3] = -1.0
        bad.append((power_pub, negative))
        _, layout = encode(points, plan, good_id)
        layout.layout.dim = layout.layout.dim[:2]
        bad.append((power_pub, layout))
        for pub, msg in bad:  # one a second: each drop gets its own (rate-limited) line
            pub.publish(msg)
            w.spin_until(lambda: False, 1.1)
        assert w.spin_until(lambda: value(bridge_status(), "bad_plan_messages") == "4", 5.0)
        last = bridge_status()
        assert last.level == DiagnosticStatus.OK, last.message
        assert value(last, "target_track_m").split()[::2] == [x0, z0]
        assert w.flown_plans[0] == [good_id.label]  # nothing new adopted
        agent_code = stop_node(agent)
        agent_out = agent.stdout.read()
    finally:
        stop_node(bridge)
        bridge_out = bridge.stdout.read()
        vehicle.stop()
    assert agent_code == 0
    dropped = [line for line in agent_out.splitlines() if "dropped plan message" in line]
    # each its own line: the first without a count, the next ones with the count so far
    assert [line.endswith(f"{n} in all)") for n, line in enumerate(dropped[1:], 2)] == \
        [True] * 3 and len(dropped) == 4, agent_out
    for text, line in zip(["formation: poses[0].position.x: value nan",
                           "formation: poses[1].position.z: value 1e+39",
                           "formation/power: data[3]: value -1.0",
                           "formation/power: layout.dim: value ['uav', 'slot']"],
                          dropped, strict=True):
        assert f"uav0: dropped plan message: {text} is not allowed" in line, line
    assert agent_out.count("uav0: flying plan") == 1, agent_out
    bridge_dropped = [line for line in bridge_out.splitlines()
                      if "dropped plan message" in line]
    assert [line.endswith(f"{n} in all)") for n, line in enumerate(bridge_dropped[1:], 2)] == \
        [True] * 3 and len(bridge_dropped) == 4, bridge_out
    assert bridge_out.count("formation received") == 1, bridge_out


def test_a_planner_restarted_infeasible_still_reports_the_agents(watcher, procs):
    w = watcher
    agent, = start_agents(procs, [1])
    assert w.spin_until(lambda: w.node.count_publishers("/uav1/achieved_rate"), 20.0)
    planner = procs("planner", *COMMON)
    assert w.spin_until(lambda: w.flown_plans[1], 30.0), "the agent took no plan"
    flown = w.flown_plans[1][-1]
    stop_cleanly([planner])
    restarted = procs("planner", *COMMON, "-p", INFEASIBLE)
    since = len(w.diagnostics)
    # STALE until the agent's next slot rate reaches the new planner, then WARN.
    assert w.spin_until(lambda: any(s.level == DiagnosticStatus.WARN
                                    for s in diag(w, "planner: uav1", since)), 30.0), \
        [s.message for s in diag(w, "planner: uav1", since)]
    last = w.statuses()
    assert last["planner: plan"].level == DiagnosticStatus.ERROR
    assert "infeasible" in last["planner: plan"].message
    uav1 = last["planner: uav1"]
    assert uav1.level == DiagnosticStatus.WARN
    assert uav1.message.startswith(f"flies {flown}, not this planner's (this planner has "
                                   "none): rate margin"), uav1.message
    assert value(uav1, "plan_flown") == flown and value(uav1, "plan_published") == ""
    assert value(uav1, "position_error_m") == "nan"  # no target of this planner's for it
    assert "planner: uav0" not in last and "planner: uav2" not in last  # no agents there
    stop_cleanly([restarted, agent])
