"""A UAV lost and back, end to end: uav1's stack (its agent and a bridge with gcs_timeout_s)
runs on a ROS domain of its own, joined to the ground's (planner, agents 0 and 2) by the radio
relay (test/radio_relay.py, the fault injection: the radio goes out of range both ways, then
comes back). The planner declares uav1 lost and re-plans the survivors; uav1's bridge times
out on the ground's silence and holds its vehicle (a simulated one, over loopback UDP) in
LOITER. Back in range it receives the survivors' plan, where it is NaN: no target, so it keeps
holding and never flies into their formation; the planner reports it heard again, and does
not re-plan it in.

Until the bridge's `uav_id` exists, uav1's bridge is the all-in-one bridge given the three
sysids on one link where only uav1's vehicle (sysid 3) answers: it flies formation point 1."""
from __future__ import annotations

import math
import os
import time

import pytest
import rclpy
from clean_stop import assert_clean, stop_and_read
from radio_relay import RadioRelay

from uav_insar_planner.demo.processes import start_node
from uav_insar_planner.ros.plan_msgs import decode_power
from uav_insar_planner.ros.swarm_watch import SWARM_STATUS_NAME
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(120)
N = 60
TIME_SCALE = 4.0
UAV_TIMEOUT_S = 2.0
GCS_TIMEOUT_S = 1.5
K = 1


def last_slot(w, k) -> int:
    return int(w.offloads[k][-1][0]) if w.offloads[k] else -1


def relayed_bridge(w):
    found = [s for m in w.diagnostics for s in m.status if s.name == f"mavlink_bridge: uav{K}"]
    return found[-1] if found else None


def test_a_lost_uav_back_in_range_keeps_holding_out_of_the_survivors_plan(
        watcher, procs, another_domain):
    w = watcher
    uav_ctx = rclpy.Context()
    rclpy.init(args=["uav"], context=uav_ctx, domain_id=another_domain)
    radio = RadioRelay(w.node.context, uav_ctx, K)
    w.add_node(radio.ground_node)
    vehicle = SimVehicle(2 + K, "udpin:127.0.0.1:0", "ardupilot",
                         start_ned=(0.0, 0.0, -40.0), max_speed=20.0, max_accel=10.0,
                         airborne=True)
    vehicle.start()
    common = ["-p", f"num_slots:={N}"]
    uav_env = dict(os.environ, ROS_DOMAIN_ID=str(another_domain))
    uav_side = [
        start_node("agent", [*common, "-p", f"uav_id:={K}", "-p", f"time_scale:={TIME_SCALE}",
                             "-r", f"__node:=agent{K}"], uav_env),
        start_node("mavlink_bridge", ["-p", f"connections:=['udpout:127.0.0.1:{vehicle.port}']",
                                      "-p", "target_sysids:=[2, 3, 4]", "-p", "speed_mps:=2.0",
                                      "-p", f"gcs_timeout_s:={GCS_TIMEOUT_S}"], uav_env)]
    ground = [procs("agent", *common, "-p", f"uav_id:={k}", "-p", f"time_scale:={TIME_SCALE}",
                    "-r", f"__node:=agent{k}") for k in (0, 2)]
    planner = None
    try:
        assert w.spin_until(lambda: w.agents_matched() and radio.uav_node.count_publishers(
            f"/uav{K}/achieved_rate"), 30.0, ground + uav_side), "agents not seen"
        planner = procs("planner", *common, "-p", f"uav_timeout_s:={UAV_TIMEOUT_S}")
        everyone = [planner, *ground, *uav_side]

        def flying():
            s = relayed_bridge(w)
            gcs = {kv.key: kv.value for kv in s.values}.get("gcs", "") if s else ""
            return (last_slot(w, K) >= 4 and vehicle.mode == "GUIDED"
                    and vehicle.setpoints_accepted > 20 and gcs.startswith("heard "))

        assert w.spin_until(flying, 40.0, everyone), (last_slot(w, K), vehicle.mode,
                                                     relayed_bridge(w))
        radio.set_up(False)
        cut_at = time.monotonic()
        w.spin_until(lambda: vehicle.mode == "LOITER", GCS_TIMEOUT_S + 5.0, everyone)
        held_after = time.monotonic() - cut_at  # (waited longer, to say how late it was)
        assert vehicle.mode == "LOITER" and held_after <= GCS_TIMEOUT_S + 1.0, \
            (vehicle.mode, held_after, relayed_bridge(w))
        assert w.spin_until(lambda: len(w.formations) >= 2 and len(w.powers) >= 2,
                            UAV_TIMEOUT_S + 3.0, everyone), "no re-plan"
        survivors = w.formations[-1]
        assert math.isnan(survivors.poses[K].position.x)
        survivors_plan = decode_power(w.powers[-1]).plan_id.label
        where = vehicle.position_ned
        accepted = vehicle.setpoints_accepted

        radio.set_up(True)
        assert w.spin_until(lambda: w.flown_plans[K] and w.flown_plans[K][-1] == survivors_plan,
                            10.0, everyone), (w.flown_plans[K], survivors_plan)
        w.spin_until(lambda: False, 2.5)
        assert vehicle.mode == "LOITER"
        assert vehicle.setpoints_accepted == accepted  # no target: nothing streamed
        assert math.dist(vehicle.position_ned, where) < 1.0
        status = relayed_bridge(w)
        assert "no target in the current plan" in status.message, status.message
        swarm = [s for m in w.diagnostics for s in m.status if s.name == SWARM_STATUS_NAME][-1]
        values = {kv.key: kv.value for kv in swarm.values}
        assert "heard again since, not re-planned" in values[f"uav{K}"], values
        assert len(w.formations) == 2  # not re-planned in
    finally:
        radio.set_up(True)
        stopped = ([planner] if planner else []) + ground + uav_side
        codes, outs = stop_and_read(stopped)
        vehicle.stop()
        radio.destroy()
        uav_ctx.try_shutdown()
    assert_clean(stopped, codes, outs)
    out = outs[0]
    assert f"uav{K} heard again after it was lost at slot" in out, out
    bridge_out = outs[-1]
    assert "ground station silent for" in bridge_out
    assert f"no target in the new plan for uav{K}: keeps holding" in bridge_out, bridge_out
    print(f"uav{K} in LOITER {held_after:.2f} s after the radio cut (gcs_timeout_s "
          f"{GCS_TIMEOUT_S:g})")
