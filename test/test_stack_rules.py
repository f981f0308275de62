"""The rules of a stack per UAV without a ROS graph: the bridge's configuration with `uav_id`,
who wins a claim, when the planner starts the pass, the start message's validation and the
bridge's track clock under a planner start."""
from __future__ import annotations

import dataclasses
import math
import time

import pytest
from std_msgs.msg import Header

from uav_insar_planner.mavlink.config import IN_CODE_DEFAULTS, BridgeConfig, from_parameters
from uav_insar_planner.mavlink.start_gate import planner_start
from uav_insar_planner.param_specs.nodes import BRIDGE_SPECS
from uav_insar_planner.ros.claims import Claim, refusal
from uav_insar_planner.ros.plan_msgs import PlanId, PlanMessageError
from uav_insar_planner.ros.start_capture import POSE_FRESH_S, all_captured, not_captured
from uav_insar_planner.ros.start_msgs import PLAUSIBLE_S, decode_start, encode_start
from uav_insar_planner.swarm import MAX_UAVS
from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_planner.track.speed_profile import RAMP_MPS2, ramp_up
from uav_insar_planner.track.trajectory import PassTrajectory

DEFAULTS = {s.name: s.default for s in BRIDGE_SPECS}


def test_a_uav_id_takes_that_uavs_default_entry_and_every_bridge_the_planners_start():
    config = from_parameters(dict(DEFAULTS, uav_id=2))
    config.validate()
    assert config.connections == ("udpout:127.0.0.1:14572",)
    assert config.target_sysids == (4,)
    assert config.uavs() == (2,)
    assert config.pass_start == "planner"
    everyone = from_parameters(DEFAULTS)
    # the all-in-one bridge too: one mission clock, which the agents' slots follow
    assert everyone.uavs() == (0, 1, 2) and everyone.pass_start == "planner"
    own = from_parameters(dict(DEFAULTS, uav_id=1, connections=["tcp:10.0.0.2:5760"],
                               target_sysids=[7], pass_start="capture"))
    assert own.connections == ("tcp:10.0.0.2:5760",) and own.target_sysids == (7,)
    assert own.pass_start == "capture"


def test_a_config_built_in_code_has_the_nodes_defaults_but_starts_its_own_pass():
    """BridgeConfig's fields are BRIDGE_SPECS in their order, with their defaults; only the
    two "auto" values differ: a config built in code starts at capture, hears no ground."""
    built = BridgeConfig()
    built.validate()
    assert [f.name for f in dataclasses.fields(built)] == [s.name for s in BRIDGE_SPECS]
    node = from_parameters(DEFAULTS)
    assert dataclasses.replace(node, **IN_CODE_DEFAULTS) == built
    assert (node.pass_start, node.gcs_timeout_s) == ("planner", 0.0)
    assert (built.pass_start, built.gcs_timeout_s) == ("capture", 0.0)
    assert built.origin_ned_m == (0.0, 0.0, 0.0) and built.target_sysids == (2, 3, 4)


@pytest.mark.parametrize("k", [3, 5, MAX_UAVS - 1])
def test_a_stack_of_a_larger_swarm_gets_its_own_default_vehicle(k):
    """uav_id 3..9 (a swarm of 4 to 10) with the default wiring: that UAV's own port and sysid,
    as uav-insar-vehicle --sysid 2+K --listen udpin:127.0.0.1:14552+10K serves it."""
    config = from_parameters(dict(DEFAULTS, uav_id=k))
    config.validate()
    assert config.connections == (f"udpout:127.0.0.1:{14552 + 10 * k}",)
    assert config.target_sysids == (2 + k,) and config.uavs() == (k,)


@pytest.mark.parametrize("change,field", [
    ({"uav_id": MAX_UAVS}, "uav_id"), ({"uav_id": -2}, "uav_id"),
    ({"uav_id": 0, "target_sysids": [2, 3]}, "target_sysids"),
    ({"uav_id": 0, "target_sysids": [2], "connections": ["udpout:a:1", "udpout:b:2"]},
     "connections")])
def test_a_bad_stack_config_is_one_line_naming_the_field(change, field):
    with pytest.raises(ValueError) as err:
        from_parameters(dict(DEFAULTS, **change)).validate()
    assert str(err.value).startswith(field) and "\n" not in str(err.value)


def test_the_oldest_claim_flies_and_ties_go_by_name():
    ours = Claim(100, 5, "/uav1/mavlink_bridge")
    older = Claim(100, 4, "/mavlink_bridge")
    younger = Claim(101, 0, "/mavlink_bridge")
    assert refusal(1, ours, [ours, younger]) is None
    line = refusal(1, ours, [ours, younger, older])
    assert line.startswith("uav1: refused, already flown by /mavlink_bridge (claimed at "
                           "100.000000004, before this bridge at 100.000000005)")
    twin_a, twin_b = Claim(100, 5, "/a/mavlink_bridge"), Claim(100, 5, "/b/mavlink_bridge")
    assert refusal(0, twin_a, [twin_b]) is None and refusal(0, twin_b, [twin_a]) is not None
    assert Claim.parse(ours.text, "t") == ours
    with pytest.raises(PlanMessageError, match="data"):
        Claim.parse("claim nobody", "uav1/mavlink/claim")


def test_the_planner_starts_only_with_every_flown_uav_fresh_and_inside_the_radius():
    starts = {0: (-27.0, 0.0, 47.0), 1: (-35.0, 0.0, 48.0)}
    now = 50.0
    near = {0: (now, (-27.0, 0.4, 47.0)), 1: (now - 0.5, (-35.3, -0.5, 48.2))}
    assert all_captured(starts, near, now, 1.0)
    assert not all_captured(starts, near, now, 0.5)  # uav1 is 0.62 m off
    assert all_captured(starts, near, now, 0.0)  # radius 0: fresh is enough
    assert not all_captured(starts, {0: near[0]}, now, 1.0)  # uav1 never heard
    stale = {**near, 1: (now - POSE_FRESH_S - 0.1, near[1][1])}
    assert not all_captured(starts, stale, now, 1.0)
    nan = {**near, 1: (now, (math.nan, 0.0, 48.0))}
    assert not all_captured(starts, nan, now, 1.0)
    assert not all_captured({}, near, now, 1.0)  # nothing flown: no start
    # what the planner says while it waits: who, and why
    assert not_captured(starts, near, now, 1.0) == {}
    assert not_captured(starts, near, now, 0.5) == {1: "0.62 m from its entry"}
    assert not_captured(starts, {0: near[0]}, now, 1.0) == {1: "no uav1/mavlink/pose yet"}
    assert not_captured(starts, stale, now, 1.0) == {1: "no uav1/mavlink/pose for 1.1 s"}
    assert not_captured(starts, nan, now, 1.0) == {1: "nan m from its entry"}


def test_the_start_message_round_trips_and_bad_ones_name_their_field():
    now = time.time()
    plan = PlanId(1_700_000_000, 5, "/planner")
    wall_ns = int(now * 1e9) + 2_000_000_000
    got_plan, got_start, offset = decode_start(encode_start(PassClock(wall_ns * 1e-9, 4.3), plan),
                                               now)
    assert got_plan == plan and got_start == pytest.approx(wall_ns * 1e-9, abs=1e-6)
    assert offset == 0.0
    for frame_id, sec, nanosec, field in (
            ("plan planner 1.000000001", int(now), 0, "frame_id"),
            (plan.label, int(now), 1_000_000_000, "stamp.nanosec"),
            (plan.label, 0, 0, "stamp"),  # 1970: a clock never set
            (plan.label, int(now + PLAUSIBLE_S) + 10, 0, "stamp")):
        bad = Header(frame_id=frame_id)
        bad.stamp.sec, bad.stamp.nanosec = sec, nanosec
        with pytest.raises(PlanMessageError) as err:
            decode_start(bad, now)
        assert err.value.field == field


def test_a_planner_start_holds_until_its_instant_then_flies_and_a_repeat_keeps_the_clock():
    track = PassTrajectory(speed_mps=4.0, duration_s=0.0)
    assert planner_start(track, 1000.0, 10.0, 998.0, "plan /planner 1.0") == ""  # no formation
    track.set_formation([(1.0, 0.0, 40.0), None, None])
    text = planner_start(track, 1000.0, 10.0, 998.0, "plan /planner 1.000000000")
    assert "in 2.00 s" in text and track.clock.start_s == pytest.approx(12.0)
    assert track.target(0, 11.9)[0] == (1.0, 0.0, 40.0)  # held at the start point
    # from the hover: the target ramps up (RAMP_MPS2), then cruises
    assert track.target(0, 13.0)[0] == pytest.approx((1.0, ramp_up(1.0, 4.0)[0], 40.0))
    assert track.target(0, 20.0)[0] == pytest.approx((1.0, ramp_up(8.0, 4.0)[0], 40.0))
    assert ramp_up(8.0, 4.0)[:2] == pytest.approx((4.0 * (8.0 - 2.0 / RAMP_MPS2), 4.0))
    # the same instant under a re-plan's identity, read a moment later: the clock stays
    assert planner_start(track, 1000.0, 11.0, 999.0 + 2e-6, "plan /planner 2.0") == ""
    assert track.clock.start_s == pytest.approx(12.0)
    # and heard again by a thread held 20 ms between its two clock reads (a busy computer):
    # the same start, not a new one from a hover
    assert planner_start(track, 1000.0, 11.0, 999.0 + 0.02, "plan /planner 2.0") == ""
    assert track.clock.start_s == pytest.approx(12.0)
    late = planner_start(track, 990.0, 11.0, 999.0, "plan /planner 3.000000000")
    assert "ago (joining the pass)" in late and track.clock.start_s == pytest.approx(2.0)
