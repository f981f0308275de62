"""The mission clock's parts, without processes: the start message with a resume offset, the
planner's choice of where a pass resumes, the bridge's track clock and its holds, and the
agent's slots flown off the planned speed (the processes: test_gcs_processes.py and the
network lab's test_field_faults.py)."""
from __future__ import annotations

import math

import pytest

from uav_insar_planner import load_params
from uav_insar_planner.autopilots.profiles import profile
from uav_insar_planner.mavlink.holds import Holding
from uav_insar_planner.mavlink.start_gate import lags, planner_start, resume_where_held
from uav_insar_planner.mavlink.supervision import WatchedVehicle
from uav_insar_planner.ros.plan_msgs import PlanId, PlanMessageError
from uav_insar_planner.ros.start_capture import ON_TRACK_M, POSE_FRESH_S, on_track
from uav_insar_planner.ros.start_msgs import decode_start, encode_start
from uav_insar_planner.track.catch_up import CATCH_UP_MPS, CatchUp, governed
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_planner.track.speed_profile import RAMP_MPS2
from uav_insar_planner.track.trajectory import PassTrajectory
from uav_insar_sim.observed_mission import SPEED_TOLERANCE, ObservedMission
from uav_insar_sim.slots import Phase

PLAN = PlanId(1796000000, 5, "/planner")


def test_a_start_carries_its_resume_offset_and_a_bad_one_is_refused():
    now = 1796000010.0
    assert decode_start(encode_start(PassClock(now, 4.3), PLAN), now)[1:] == (
        pytest.approx(now), 0.0)
    msg = encode_start(PassClock(now, 4.3, 31.2), PLAN)
    assert msg.frame_id == f"{PLAN.label} at 31.200 m"
    plan_id, _, offset = decode_start(msg, now)
    assert plan_id == PLAN and offset == pytest.approx(31.2)
    # a pass from the hover: its targets wait at the run-in's entry, before the start line
    msg = encode_start(PassClock(now, 4.3, -8.163), PLAN)
    assert msg.frame_id == f"{PLAN.label} at -8.163 m"
    assert decode_start(msg, now)[2] == pytest.approx(-8.163)
    for bad in (f"{PLAN.label} at -99999999.000 m", f"{PLAN.label} at 1e9 m",
                f"{PLAN.label} at x m", f"{PLAN.label} at 99999999.000 m",
                f"{PLAN.label} at --3.000 m"):
        msg.frame_id = bad
        with pytest.raises(PlanMessageError) as err:
            decode_start(msg, now)
        assert "\n" not in str(err.value) and "frame_id" in str(err.value)


STARTS = {0: (0.0, 0.0, 50.0), 1: (-20.0, 0.0, 52.0), 2: (-35.0, 0.0, 49.0)}


def _poses(past: dict[int, float], now: float, age: float = 0.1, dx: float = 0.0):
    return {k: (now - age, (STARTS[k][0] + dx, STARTS[k][1] + d, STARTS[k][2]))
            for k, d in past.items()}


def test_a_pass_under_way_resumes_from_the_rearmost_uav_and_nothing_else_does():
    now = 100.0
    found = on_track(STARTS, _poses({0: 30.4, 1: 29.9, 2: 30.1}, now), {1: 0.02}, now, 172.0)
    assert found == (1, pytest.approx(29.9), 0.02)
    # at the start line (a capture, not a resume), off the track, past the end, silent
    assert on_track(STARTS, _poses({0: 30.0, 1: 0.5, 2: 30.0}, now), {}, now, 172.0) is None
    assert on_track(STARTS, _poses({0: 30.0, 1: 30.0, 2: 30.0}, now, dx=ON_TRACK_M + 0.1),
                    {}, now, 172.0) is None
    assert on_track(STARTS, _poses({0: 180.0, 1: 180.0, 2: 180.0}, now), {}, now, 172.0) is None
    assert on_track(STARTS, _poses({0: 30.0, 1: 30.0, 2: 30.0}, now, age=POSE_FRESH_S + 0.1),
                    {}, now, 172.0) is None
    assert on_track(STARTS, _poses({0: 30.0, 1: 30.0}, now), {}, now, 172.0) is None


def test_a_resumed_pass_holds_at_its_offset_until_the_instant_then_flies_at_v():
    pass_ = PassTrajectory(4.0, 0.0)
    pass_.set_formation([(0.0, 10.0, 50.0)])
    text = planner_start(pass_, wall_time_s=1002.0, mono_now=50.0, wall_now=1000.0,
                         label=PLAN.label, offset_m=20.0)
    assert "resuming 20.00 m past the start line" in text and "in 2.00 s" in text
    (position, velocity) = pass_.target(0, 51.0)
    assert position[1] == pytest.approx(30.0) and velocity == (0.0, 0.0, 0.0)  # holds there
    # from the hover it ramps up at RAMP_MPS2 (no vehicle left to catch up), then cruises
    position, velocity = pass_.target(0, 53.0)
    assert position[1] == pytest.approx(30.0 + 0.5 * RAMP_MPS2) and velocity[1] == RAMP_MPS2
    position, velocity = pass_.target(0, 62.0)
    assert position[1] == pytest.approx(30.0 + 4.0 * (10.0 - 0.5 * 4.0 / RAMP_MPS2))
    assert velocity[1] == 4.0
    # the same start again (a re-plan) changes nothing; another offset does
    assert planner_start(pass_, 1002.0, 50.0, 1000.0, PLAN.label, 20.0) == ""
    assert planner_start(pass_, 1002.0, 50.0, 1000.0, PLAN.label, 0.0) != ""
    assert pass_.target(0, 53.0)[0][1] == pytest.approx(10.0 + 0.5 * RAMP_MPS2)
    # one heard well after its instant joins a running pass: no ramp
    assert "joining the pass" in planner_start(pass_, 990.0, 50.0, 1000.0, PLAN.label, 0.0)
    assert pass_.target(0, 50.0)[0][1] == pytest.approx(10.0 + 40.0)


def _vehicle(uav: int, north: float) -> WatchedVehicle:
    v = WatchedVehicle(uav, 2 + uav, link=None, linked=True, mode="LOITER", custom_mode=5,
                       last_heartbeat=0.0)
    v.position_ned, v.position_time = (north, 0.0, -50.0), 0.0
    return v


def test_a_held_uav_rejoins_when_near_its_target_and_says_so_when_too_far_behind():
    frame = TrackFrame.from_degrees(0.0, (0.0, 0.0, 0.0))  # along track = north
    pass_ = PassTrajectory(2.0, 0.0)
    pass_.set_formation([(0.0, 0.0, 50.0), (-20.0, 0.0, 50.0)])
    pass_.clock = PassClock(0.0, 2.0, ramp=False)  # a pass running for 10 s
    near, far = _vehicle(0, 19.0), _vehicle(1, 15.0)  # target at y = 20 at t = 10
    events: list[str] = []
    holding = Holding(profile("ardupilot"), 1.0, [0, 1], lambda k, level, text: events.append(text))
    holding.gcs_heard("gcs/heartbeat", 0.0, heartbeat=True)
    holding.check(5.0)  # silent: both held
    assert holding.stopped(near) and holding.stopped(far) and holding.gcs.silent
    holding.rejoin([near, far], lags([near, far], pass_, frame, 10.0), 2.0, "too early")
    assert holding.stopped(near)  # still silent: nobody goes
    assert holding.gcs_heard("gcs/heartbeat", 10.0, heartbeat=True)
    holding.rejoin([near, far], lags([near, far], pass_, frame, 10.0), 2.0, "heard")
    assert not holding.stopped(near) and holding.stopped(far)
    assert "5.00 m behind its target" in holding.behind[1]
    assert "cannot keep the pass" in holding.phase(far)
    assert any("rejoins the pass, 1.00 m behind" in e and "LOITER -> GUIDED" in e
               for e in events), events
    # its own clock (pass_start capture): the pass resumes where the held one stands
    assert resume_where_held(pass_, [5.0]).startswith("the pass resumes where the swarm holds")
    assert pass_.target(1, 10.0)[0][1] == pytest.approx(15.0)
    # a plan that gives it no target: it holds, whatever happens to the pass
    holding.on_plan([(0.0, 0.0, 50.0), None], True)
    assert "no target in the current plan" in holding.phase(far)


def test_a_rejoined_uav_the_next_plan_takes_out_is_ordered_to_hold_and_nothing_else():
    """Heard again, both held UAVs rejoin (GUIDED ordered); the plan that comes next gives
    uav1 no target (the survivors' plan). uav1's order is the hold alone from then on: a
    resume still engaged beside it once alternated with it and left the UAV in GUIDED."""
    a, b = _vehicle(0, 19.0), _vehicle(1, 19.0)
    holding = Holding(profile("ardupilot"), 1.0, [0, 1], lambda k, level, text: None)
    holding.gcs_heard("gcs/heartbeat", 0.0, heartbeat=True)
    holding.check(5.0)
    assert holding.gcs_heard("gcs/heartbeat", 6.0, heartbeat=True)
    assert holding.rejoin([a, b], {0: 1.0, 1: 1.0}, 2.0, "heard") == [0, 1]
    holding.on_plan([(0.0, 0.0, 50.0), None], True)
    assert holding.stopped(b) and not holding.stopped(a)
    sent = {0: [], 1: []}
    for step in range(40):  # the bridge's loop, 0.25 s a turn, for 10 s
        now = 6.0 + 0.25 * step
        for v in (a, b):
            if (order := holding.order_due(v, now)) is not None:
                sent[v.uav].append(order.mode.name)
                order.sent(v, now)
    assert sent[1] and set(sent[1]) == {"LOITER"}, sent[1]
    assert set(sent[0]) == {"GUIDED"}, sent[0]


def test_slots_flown_off_the_planned_speed_are_found():
    params = load_params(overrides={"num_slots": 6, "slot_duration_s": 1.0})
    mission = ObservedMission(0, params)
    mission.set_plan((0.0, 50.0), [1.0] * 6, y_start=0.0)
    mission.set_pass_start(PassClock(0.0, params.speed, ramp=False))  # joined at speed
    v, t, y, held = params.speed, 0.0, -0.1, 0
    mission.observe((0.0, y, 50.0), t)
    while mission.phase != Phase.DONE:  # slot 2 held for 3 s, slot 4 flown at twice the speed
        hold = y >= 2.5 * v and held < 30
        held += hold
        y += 0.0 if hold else (2.0 if 4 * v <= y < 5 * v else 1.0) * v * 0.1
        t = round(t + 0.1, 6)
        mission.observe((0.0, y, 50.0), t)
        assert t < 30.0
    durations = mission.durations()
    assert len(durations) == 6
    off = dict(mission.off_speed())
    assert set(off) == {2, 4}, durations
    assert off[2] == pytest.approx(4.0, abs=0.15) and off[4] == pytest.approx(0.5, abs=0.1)
    assert all(abs(d - 1.0) <= SPEED_TOLERANCE for n, d in enumerate(durations) if n not in off)
    assert math.isfinite(mission.end_time_s)
    # from the hover, the plan's target ramps up: slot 0 takes longer by plan, not off speed
    mission.set_pass_start(PassClock(0.0, params.speed))
    v = params.speed
    assert mission.line_time(1) == pytest.approx(math.sqrt(2.0 * v / RAMP_MPS2))
    assert mission.line_time(5) == pytest.approx(5.0 + v / (2.0 * RAMP_MPS2))
    assert mission.line_time(5) - mission.line_time(4) == pytest.approx(1.0)


def test_a_start_heard_too_late_holds_the_uav_rather_than_sprint():
    events: list[str] = []
    holding = Holding(profile("ardupilot"), 0.0, [0, 1], lambda k, level, text: events.append(text))
    on_time, late = _vehicle(0, 19.0), _vehicle(1, 0.0)
    holding.fall_back([on_time, late], {0: 1.0, 1: 9.0}, 2.0, "a new pass start")
    assert not holding.stopped(on_time) and holding.stopped(late)
    assert holding.hold.engaged(1) and "cannot keep the pass" in holding.phase(late)
    assert events == ["a new pass start: 9.00 m behind its target, more than the 2.00 m it may "
                      "catch up: cannot keep the pass, keeps holding (LOITER, no sprint)"]


def test_a_rejoining_vehicle_catches_up_at_most_1_m_s_faster_than_the_pass():
    pass_ = PassTrajectory(4.3, 0.0)
    pass_.set_formation([(0.0, 0.0, 50.0)])
    pass_.clock = PassClock(0.0, 4.3, ramp=False)  # running for 10 s at t = 10
    catch_ups = {0: CatchUp(10.0, 40.0, 4.3)}  # standing 3 m behind its target (43 m)
    speeds, t = [], 10.0
    while 0 in catch_ups:
        position, velocity = governed(catch_ups, 0, pass_.target(0, t), t)
        speeds.append(velocity[1])
        t = round(t + 0.1, 6)
        assert t < 60.0, "never caught up"
    assert max(speeds) == pytest.approx(4.3 + CATCH_UP_MPS)
    assert speeds[0] == 0.0 and speeds[:-1] == sorted(speeds[:-1])  # from rest, ramping up
    assert governed(catch_ups, 0, pass_.target(0, t), t) == pass_.target(0, t)  # the clock's
    print(f"3 m behind: caught up in {t - 10.0:.1f} s")
