"""Plan identity and validation on the wire (ros/plan_msgs.py) and the gate's pairing rule
(ros/plan_gate.PlanPairing), on real messages of a real solve; no ROS graph needed."""
from __future__ import annotations

import math

import numpy as np
import pytest
from std_msgs.msg import MultiArrayDimension

from uav_insar_planner import load_params, solve
from uav_insar_planner.mavlink.guard import DropLog
from uav_insar_planner.published import formation_points
from uav_insar_planner.ros.plan_gate import PlanPairing
from uav_insar_planner.ros.plan_msgs import (
    DROP_LOG_PERIOD_S,
    PlanId,
    PlanMessageError,
    decode_formation,
    decode_power,
    encode,
    next_stamp,
)

N = 6


@pytest.fixture(scope="module")
def plans():
    proposed = solve(load_params(overrides={"num_slots": N}))
    single = solve(load_params(overrides={"num_slots": N, "scheme": "single-baseline"}))
    return proposed, single


def test_round_trip_carries_one_identity_on_both_messages(plans):
    plan = plans[0]
    plan_id = PlanId(1733086200, 123456789, "/swarm/planner")
    formation, power = encode(formation_points(plan), plan, plan_id)
    assert power.layout.dim[2].label == "plan /swarm/planner 1733086200.123456789"
    f, p = decode_formation(formation), decode_power(power)
    assert f.stamp == p.plan_id.stamp == (1733086200, 123456789)
    assert p.plan_id == plan_id
    assert np.allclose([(x, z) for x, _, z in f.points], plan.formation)
    assert np.array_equal(p.p_com_w, plan.p_com_w)


def test_a_uav_not_flown_decodes_as_none(plans):
    f = decode_formation(encode(formation_points(plans[1]), plans[1], PlanId(1, 0, "/planner"))[0])
    assert f.points[2] is None and all(f.points[:2])


def test_stamps_increase_even_when_the_clock_does_not():
    assert next_stamp((5, 10), None) == (5, 10)
    assert next_stamp((5, 10), (5, 10)) == (5, 11)
    assert next_stamp((4, 0), (5, 999_999_999)) == (6, 0)


@pytest.mark.parametrize("k,axis,value,field", [
    (0, "x", math.nan, "poses[0].position.x"),  # NaN mix: x NaN, z finite
    (1, "z", math.nan, "poses[1].position.z"),
    (0, "x", 1e39, "poses[0].position.x"),  # finite, but not float32
    (2, "y", 2e6, "poses[2].position.y"),  # beyond the 1e6 m bound
    (1, "z", math.inf, "poses[1].position.z"),
])
def test_bad_formation_names_the_field_and_value(plans, k, axis, value, field):
    formation, _ = encode(formation_points(plans[0]), plans[0], PlanId(1, 0, "/planner"))
    setattr(formation.poses[k].position, axis, value)
    with pytest.raises(PlanMessageError) as err:
        decode_formation(formation)
    assert str(err.value).startswith(f"formation: {field}: value ")
    assert "\n" not in str(err.value)


def _bad_power(power, case):
    dim = power.layout.dim
    if case == "negative":
        power.data[4] = -0.5
    elif case == "nan":
        power.data[0] = math.nan
    elif case == "float32":
        power.data[1] = 1e39
    elif case == "two dims":
        power.layout.dim = dim[:2]
    elif case == "short data":
        power.data = power.data[:-1]
    elif case == "stride":
        dim[1].stride = N + 1
    elif case == "label":
        dim[2].label = "plan planner 12"
    return power


@pytest.mark.parametrize("case,field", [
    ("negative", "data[4]"), ("nan", "data[0]"), ("float32", "data[1]"),
    ("two dims", "layout.dim"), ("short data", "data"), ("stride", "layout.dim strides"),
    ("label", "layout.dim[2].label")])
def test_bad_power_names_the_field(plans, case, field):
    _, power = encode(formation_points(plans[0]), plans[0], PlanId(1, 0, "/planner"))
    with pytest.raises(PlanMessageError) as err:
        decode_power(_bad_power(power, case))
    assert str(err.value).startswith(f"formation/power: {field}: value ")


def test_a_long_value_is_cut_short(plans):
    _, power = encode(formation_points(plans[0]), plans[0], PlanId(1, 0, "/planner"))
    power.layout.dim[2] = MultiArrayDimension(label="x" * 500, size=1, stride=1)
    with pytest.raises(PlanMessageError) as err:
        decode_power(power)
    assert len(str(err.value)) < 150 and "..." in str(err.value)


def test_a_bad_plan_message_logs_at_most_one_line_a_second():
    clock = [0.0]
    log = DropLog(DROP_LOG_PERIOD_S, clock=lambda: clock[0])
    lines = []
    for t in (0.0, 0.2, 0.4, 1.5):
        clock[0] = t
        lines.append(log.drop("plan message", "bad"))
    shown = [line for line in lines if line is not None]
    assert log.total == 4 and len(shown) == 2
    assert shown[1] == "dropped plan message: bad (3 since the last report, 4 in all)"


def _pair(pairing, plan, plan_id, order="fp"):
    formation, power = encode(formation_points(plan), plan, plan_id)
    for which in order:
        if which == "f":
            pairing.add_formation(decode_formation(formation))
        else:
            pairing.add_power(decode_power(power))


def test_pairing_never_mixes_two_plans(plans):
    proposed, single = plans
    a, b = PlanId(10, 0, "/planner"), PlanId(11, 0, "/planner2")
    pairing = PlanPairing()
    _pair(pairing, proposed, a, "f")  # a formation without its power waits
    assert pairing.choose(["/planner"], ["/planner"]) is None
    _pair(pairing, single, b, "p")  # another plan's power never completes it
    assert pairing.choose(["/planner"], ["/planner"]) is None
    _pair(pairing, proposed, a, "p")
    f, p = pairing.choose(["/planner"], ["/planner"])
    assert f.stamp == p.plan_id.stamp == a.stamp
    assert pairing.choose(["/planner"], ["/planner"]) is None  # already in use


def test_pairing_holds_while_two_planners_publish_and_takes_the_survivors_plan(plans):
    proposed, single = plans
    a, b = PlanId(10, 0, "/planner"), PlanId(11, 0, "/planner2")
    pairing = PlanPairing()
    _pair(pairing, proposed, a)
    assert pairing.choose(["/planner"], ["/planner"])[1].plan_id == a
    # The latched race: planner2's plan arrives while the graph still shows only /planner.
    _pair(pairing, single, b)
    assert pairing.choose(["/planner"], ["/planner"]) is None
    both = ["/planner", "/planner2"]
    assert pairing.choose(both, both) is None and pairing.current == a
    assert pairing.choose(["/planner2"], ["/planner2"])[1].plan_id == b  # /planner is gone
    # An older plan of a planner never replaces its newer one.
    _pair(pairing, proposed, PlanId(9, 0, "/planner2"))
    assert pairing.latest["/planner2"][1].plan_id == b


def test_a_planner_gone_from_the_graph_is_forgotten(plans):
    """Restarted under the same name, a planner's predecessor's plan is never adopted for it."""
    proposed, single = plans
    pairing = PlanPairing()
    both = ["/planner", "/planner2"]
    _pair(pairing, proposed, PlanId(10, 0, "/planner"))
    _pair(pairing, single, PlanId(11, 0, "/planner2"))
    assert pairing.choose(both, both) is None
    assert pairing.choose(["/planner"], ["/planner"])[1].plan_id.planner == "/planner"
    assert "/planner2" not in pairing.latest  # it left the graph: forgotten
    assert pairing.choose(both, both) is None  # /planner2 restarted, its plan not here yet
    assert pairing.choose(["/planner2"], ["/planner2"]) is None  # /planner left
    _pair(pairing, single, PlanId(12, 0, "/planner2"))
    assert pairing.choose(["/planner2"], ["/planner2"])[1].plan_id == PlanId(12, 0, "/planner2")


def test_a_killed_planner_still_in_the_graph_beside_its_successor_gives_way_to_it(plans):
    """SIGKILLed, a planner's participant stays in the graph until the lease expires (20 s):
    its successor under the same name is followed at once with its own, newer plan."""
    proposed, single = plans
    pairing = PlanPairing()
    _pair(pairing, proposed, PlanId(10, 0, "/planner"))
    assert pairing.choose(["/planner"], ["/planner"])[1].plan_id == PlanId(10, 0, "/planner")
    twice = ["/planner", "/planner"]
    assert pairing.choose(twice, twice) is None  # nothing new yet
    _pair(pairing, single, PlanId(30, 0, "/planner"))  # the successor's plan
    assert pairing.choose(twice, twice)[1].plan_id == PlanId(30, 0, "/planner")
    assert pairing.choose(twice, ["/planner", "/planner2"]) is None  # two names: holds


def _leg(strip: int = 3, sortie: int = 1, last: bool = True, heading_deg: float = 271.5,
         origin=(12.345, -67.89, 0.0), length_m: float = 120.0):
    from uav_insar_planner.track.frame import TrackFrame
    from uav_insar_planner.track.leg import SurveyLeg
    return SurveyLeg(strip, sortie, last, TrackFrame.from_degrees(heading_deg, origin), length_m)


@pytest.mark.parametrize("last", [True, False])
def test_a_survey_strip_rides_in_the_formation_frame_id_and_comes_back(last):
    import math

    from uav_insar_planner.ros.plan_msgs import decode_leg, encode_leg
    leg = _leg(last=last)
    text = encode_leg(leg)
    assert text.startswith("insar_track: strip 3, sortie 1, attempt 1")
    assert ("last" in text) == last
    back = decode_leg(text)
    assert (back.strip, back.sortie, back.last, back.length_m) == (3, 1, last, 120.0)
    assert math.isclose(back.frame.bearing_rad, leg.frame.bearing_rad, abs_tol=1e-6)
    assert back.frame.origin_ned == pytest.approx(leg.frame.origin_ned, abs=1e-3)
    assert decode_leg("insar_track") is None and decode_leg("") is None


@pytest.mark.parametrize("frame_id, field", [
    ("map", "header.frame_id"),
    ("insar_track: strip 3, sortie 1, attempt 0; heading 4.0000 deg; origin N 0.000 E 0.000 "
     "D 0.000 m; length 10.000 m", "header.frame_id"),
    ("insar_track: strip 3, sortie 1, attempt 1; heading 400.0000 deg; origin N 0.000 "
     "E 0.000 D 0.000 m; length 10.000 m", "header.frame_id"),
    ("insar_track: strip 3, sortie 1, attempt 1; heading 10.0000 deg; origin N 0.000 E 0.000 "
     "D 0.000 m; length 0.000 m", "header.frame_id"),
    ("insar_track: strip -3, sortie 1, attempt 1; heading 10.0000 deg; origin N 0.000 "
     "E 0.000 D 0.000 m; length 5.000 m", "header.frame_id")])
def test_a_bad_strip_frame_id_is_refused_naming_the_field(frame_id, field):
    from uav_insar_planner.ros.plan_msgs import PlanMessageError, decode_leg
    with pytest.raises(PlanMessageError) as err:
        decode_leg(frame_id)
    assert err.value.field == field and "\n" not in str(err.value)


def test_a_strip_frame_is_placed_by_the_home_of_each_vehicle():
    from uav_insar_planner.track.frame import TrackFrame
    leg = _leg(heading_deg=90.0, origin=(10.0, 20.0, 0.0))
    a = leg.placed(TrackFrame.from_degrees(0.0, (0.0, 0.0, 0.0)))
    b = leg.placed(TrackFrame.from_degrees(30.0, (-5.0, 7.0, 0.0)))  # the bearing is not used
    # slot 0's line start of the master, seen by two vehicles booted 8.6 m apart
    pa, pb = a.to_ned(0.0, 0.0, 10.0), b.to_ned(0.0, 0.0, 10.0)
    assert pa == pytest.approx((10.0, 20.0, -10.0))
    assert pb == pytest.approx((5.0, 27.0, -10.0))
    # flying along the strip is flying east, for both
    assert a.to_ned(0.0, 5.0, 0.0)[1] - pa[1] == pytest.approx(5.0)
    assert b.to_ned(0.0, 5.0, 0.0)[1] - pb[1] == pytest.approx(5.0)
