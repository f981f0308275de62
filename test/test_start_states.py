"""The planner's pass start as states (ros/start_states.py), stepped without a node: what it
publishes, says and declares lost for what it hears. The node around it with bridges played
by a test: test_pass_resume.py; with the real bridges: test_per_uav_stacks.py."""
from __future__ import annotations

import math
from dataclasses import dataclass

import pytest

from uav_insar_planner.ros.start_confirmations import CONFIRM_MARGIN_S
from uav_insar_planner.ros.start_states import (
    BEHIND_GRACE_S,
    MOVING_BACKDATE_S,
    RESTARTED_DELAY_S,
    WAIT_LOG_PERIOD_S,
    BridgeReport,
    DeclareLost,
    Log,
    NewPlan,
    Now,
    Observed,
    Phase,
    Publish,
    StartState,
    step,
)
from uav_insar_planner.track.pass_clock import SAME_LINE_M, PassClock
from uav_insar_planner.track.passes import run_in_m


@dataclass(frozen=True)
class _Plan:
    """A plan identity as the start names it (ros/plan_msgs.PlanId has the same two)."""

    label: str

    def __str__(self) -> str:
        return self.label


SPEED, LENGTH, DELAY, RADIUS, WAIT = 4.3, 172.0, 2.0, 1.0, 20.0
WALL0 = 1_796_000_000.0  # wall clock at monotonic 0
POINTS = [(-27.0, 10.0, 47.0), (-35.0, 10.0, 48.0), (-43.0, 10.0, 49.0)]
PLAN, REPLAN = _Plan("plan /planner 1.000000001"), _Plan("plan /planner 2.000000002")
RUN_IN = run_in_m(SPEED)  # the UAVs wait for the pass at their entries, this far before it


def _now(t: float) -> Now:
    return Now(t, WALL0 + t)


def _seen(t: float, along: dict[int, float], *, reports: tuple[BridgeReport, ...] = (),
          speeds: dict[int, float] | None = None, lost: frozenset[int] = frozenset(),
          bridged: bool = True, dx: float = 0.0) -> Observed:
    """Poses heard at `t`, UAV k `along[k]` m past its start point (dx across track)."""
    poses = {k: (t, (POINTS[k][0] + dx, POINTS[k][1] + d, POINTS[k][2]))
             for k, d in along.items()}
    return Observed(poses, speeds or {}, reports, lost, RADIUS, DELAY, WAIT, bridged)


def _waiting(along: dict[int, float]) -> dict[int, float]:
    """`along[k]` m past UAV k's entry, as `_seen` takes it (past its start point)."""
    return {k: d - RUN_IN for k, d in along.items()}


def _planned(t: float = 0.0, plan: _Plan = PLAN, points=POINTS) -> StartState:
    state, actions = step(StartState(), NewPlan(plan, points, SPEED, LENGTH), _now(t))
    assert state.phase is Phase.AWAITING_CAPTURE and actions == ()
    return state


def _started(t: float = 1.0) -> StartState:
    state, actions = step(_planned(), _seen(t, _waiting({0: 0.0, 1: 0.3, 2: -0.2})), _now(t))
    assert state.phase is Phase.STARTED and isinstance(actions[0], Publish)
    return state


def _behind(k: int, t: float, plan: _Plan = PLAN) -> BridgeReport:
    return BridgeReport(k, t, None, "12.3 m behind its target", plan.label)


def _logs(actions) -> list[tuple[str, str]]:
    return [(a.level, a.text) for a in actions if isinstance(a, Log)]


def test_no_plan_nothing_happens():
    state, actions = step(StartState(), _seen(1.0, {0: 0.0, 1: 0.0, 2: 0.0}), _now(1.0))
    assert state == StartState() and actions == ()


def test_every_flown_uav_captured_starts_the_pass_once_at_now_plus_the_delay():
    state = _planned()
    # one outside the radius: no start yet
    state, actions = step(state, _seen(1.0, _waiting({0: 0.0, 1: 1.5, 2: 0.0})), _now(1.0))
    assert state.phase is Phase.AWAITING_CAPTURE and actions == ()
    state, actions = step(state, _seen(2.0, _waiting({0: 0.0, 1: 0.3, 2: -0.2})), _now(2.0))
    assert state.phase is Phase.STARTED
    clock = PassClock(WALL0 + 2.0 + DELAY, SPEED, -RUN_IN)  # from the hover at the entries
    assert actions == (Publish(clock, PLAN), Log("info", (
        f"every flown UAV (uav0, uav1, uav2) within 1 m of its entry: the pass starts in 2 s, "
        f"wall clock {WALL0 + 4.0:.3f} ({PLAN.label})")))
    assert state.started == {PLAN.label}
    # started: captured again later is no second start
    assert step(state, _seen(3.0, _waiting({0: 0.0, 1: 0.0, 2: 0.0})), _now(3.0))[1] == ()
    # at the start points, a run-in ahead of the entries: not captured
    state, actions = step(_planned(), _seen(4.0, {0: 0.0, 1: 0.0, 2: 0.0}), _now(4.0))
    assert state.phase is Phase.AWAITING_CAPTURE and actions == ()


def test_a_uav_not_flown_or_lost_is_not_waited_for():
    points = [POINTS[0], (math.nan,) * 3, POINTS[2]]
    state, actions = step(_planned(points=points), _seen(1.0, _waiting({0: 0.0, 2: 0.0})),
                          _now(1.0))
    assert state.phase is Phase.STARTED and "(uav0, uav2)" in actions[1].text
    state, actions = step(_planned(), _seen(1.0, _waiting({0: 0.0, 2: 0.0}), lost=frozenset({1})),
                          _now(1.0))
    assert state.phase is Phase.STARTED


def test_a_waiting_capture_is_said_every_period_naming_who_and_why():
    state = _planned(t=0.0)
    along = _waiting({0: 0.0, 1: 2.5})  # uav1 too far, uav2 never heard
    early = WAIT_LOG_PERIOD_S - 0.1
    assert step(state, _seen(early, along), _now(early))[1] == ()
    # a swarm with no bridge (self-flown agents): nothing said
    assert step(state, _seen(WAIT_LOG_PERIOD_S, along, bridged=False),
                _now(WAIT_LOG_PERIOD_S))[1] == ()
    state, actions = step(state, _seen(WAIT_LOG_PERIOD_S, along), _now(WAIT_LOG_PERIOD_S))
    assert _logs(actions) == [("info", "the pass start waits for uav1 (2.50 m from its entry), "
                                       "uav2 (no uav2/mavlink/pose yet): "
                                       f"capture_radius_m 1 ({PLAN.label})")]
    t = 1.5 * WAIT_LOG_PERIOD_S  # not again before the next period
    assert step(state, _seen(t, along), _now(t))[1] == ()
    t = 2.0 * WAIT_LOG_PERIOD_S
    assert len(_logs(step(state, _seen(t, along), _now(t))[1])) == 1


def test_a_replan_on_the_same_start_line_publishes_the_same_instant_under_its_identity():
    state = _started()
    points = [(x + 3.0, y + 0.5 * SAME_LINE_M, z) for x, y, z in POINTS]
    again, actions = step(state, NewPlan(REPLAN, points, SPEED, LENGTH), _now(5.0))
    assert again.phase is Phase.STARTED and again.clock == state.clock
    assert actions == (Publish(state.clock, REPLAN),
                       Log("info", f"pass continues: the same start again for {REPLAN}"))
    assert again.started == {PLAN.label, REPLAN.label}


def test_a_plan_on_another_start_line_waits_for_a_new_capture():
    state = _started()
    points = [(x, y + 2.0 * SAME_LINE_M, z) for x, y, z in POINTS]
    moved, actions = step(state, NewPlan(REPLAN, points, SPEED, LENGTH), _now(5.0))
    assert moved.phase is Phase.AWAITING_CAPTURE and moved.clock is None and actions == ()
    # the hold plan (nothing flown) too, and it never starts
    held, actions = step(state, NewPlan(REPLAN, [(math.nan,) * 3] * 3, SPEED, 0.0), _now(5.0))
    assert held.phase is Phase.AWAITING_CAPTURE and actions == ()
    assert step(held, _seen(6.0, _waiting({0: 0.0})), _now(6.0))[1] == ()


def test_every_flown_uav_behind_resumes_from_the_rearmost_after_the_delay():
    state = _started()
    along = {0: 30.0, 1: 27.5, 2: 29.0}
    reports = tuple(_behind(k, 40.0) for k in (0, 1))
    state, actions = step(state, _seen(40.0, along, reports=reports), _now(40.0))
    assert actions == ()  # uav2 flies on
    state, actions = step(state, _seen(40.5, along, reports=(_behind(2, 40.5),)), _now(40.5))
    assert state.phase is Phase.RESUME_UNCONFIRMED and state.behind == {}
    clock = PassClock(WALL0 + 40.5 + DELAY, SPEED, 27.5)
    assert actions == (Publish(clock, PLAN), Log("warning", (
        "resuming the pass where the swarm is: every flown UAV holds behind its target; from "
        "27.50 m past the start line (uav1, the rearmost), in 2 s, at 4.3 m/s, wall clock "
        f"{clock.start_s:.3f} ({PLAN.label})")))


def test_behind_on_a_plan_this_planner_did_not_start_counts_for_nothing():
    state = _started()
    reports = tuple(_behind(k, 40.0, REPLAN) for k in (0, 1, 2))
    state, actions = step(state, _seen(40.0, {0: 30.0, 1: 30.0, 2: 30.0}, reports=reports),
                          _now(40.0))
    assert actions == () and state.behind == {}


def test_one_behind_alone_longer_than_the_grace_is_declared_lost():
    state = _started()
    along = {0: 30.0, 1: 22.0, 2: 30.0}
    t0 = 40.0
    state, _ = step(state, _seen(t0, along, reports=(_behind(1, t0),)), _now(t0))
    t = t0 + BEHIND_GRACE_S - 0.1  # (a report a second, as the bridges say it)
    state, actions = step(state, _seen(t, along, reports=(_behind(1, t),)), _now(t))
    assert actions == ()
    t = t0 + BEHIND_GRACE_S + 0.1
    state, actions = step(state, _seen(t, along, reports=(_behind(1, t),)), _now(t))
    assert actions == (DeclareLost(1, "12.3 m behind its target"),)
    assert 1 not in state.behind and state.phase is Phase.STARTED


def test_a_restarted_planner_finding_the_uavs_on_track_resumes_after_the_longer_delay():
    state = _planned()
    along = {0: 30.4, 1: 29.9, 2: 30.1}
    state, actions = step(state, _seen(1.0, along, speeds={1: 0.02}), _now(1.0))
    wait = max(DELAY, RESTARTED_DELAY_S)
    assert state.phase is Phase.RESUME_UNCONFIRMED
    assert state.clock == PassClock(WALL0 + 1.0 + wait, SPEED, pytest.approx(29.9))
    assert actions[0] == Publish(state.clock, PLAN)
    assert _logs(actions) == [("warning", (
        "resuming the pass where the swarm is: the UAVs are on their tracks past the start line "
        "(this planner started again?); from 29.90 m past the start line (uav1, the rearmost), "
        f"in {wait:g} s, at 4.3 m/s, wall clock {WALL0 + 1.0 + wait:.3f} ({PLAN.label})"))]


def test_a_restarted_planner_finding_the_swarm_flying_resumes_at_once_backdated():
    state = _planned()
    along = {0: 30.4, 1: 29.9, 2: 30.1}
    state, actions = step(state, _seen(1.0, along, speeds={1: 0.6 * SPEED}), _now(1.0))
    assert state.phase is Phase.STARTED and state.awaited is None  # nothing to confirm
    past = 29.9 - SPEED * MOVING_BACKDATE_S
    assert state.clock == PassClock(WALL0 + 1.0 - MOVING_BACKDATE_S, SPEED, pytest.approx(past))
    assert f"from {past:.2f} m past the start line (uav1, the rearmost), at once (still " \
           "flying)" in actions[1].text
    # off its track line: no resume, the capture is awaited
    state, actions = step(_planned(), _seen(1.0, along, dx=2.5), _now(1.0))
    assert state.phase is Phase.AWAITING_CAPTURE and actions == ()


def _resumed(t: float = 1.0) -> StartState:
    state, _ = step(_planned(), _seen(t, {0: 30.0, 1: 30.0, 2: 30.0}), _now(t))
    assert state.phase is Phase.RESUME_UNCONFIRMED
    return state


def _confirming(t: float, instant: float, uavs=(0, 1, 2)) -> tuple[BridgeReport, ...]:
    return tuple(BridgeReport(k, t, instant, "", PLAN.label) for k in uavs)


def test_a_resumed_start_every_bridge_confirms_stands():
    state = _resumed()
    start = state.clock.start_s
    t = start - WALL0 - 1.0
    state, actions = step(state, _seen(t, {0: 30.0, 1: 30.0, 2: 30.0},
                                       reports=_confirming(t, start + 0.0004)), _now(t))
    assert actions == () and state.phase is Phase.RESUME_UNCONFIRMED  # not yet decided
    t = start - WALL0 - 0.1
    state, actions = step(state, _seen(t, {0: 30.0, 1: 30.0, 2: 30.0}), _now(t))
    assert actions == () and state.phase is Phase.STARTED and state.clock.start_s == start


def test_an_unconfirmed_resumed_start_moves_later_then_is_given_up():
    state = _resumed(t=1.0)
    along = {0: 30.0, 1: 30.0, 2: 30.0}
    start = state.clock.start_s
    t = start - WALL0 - CONFIRM_MARGIN_S + 0.05
    state, actions = step(state, _seen(t, along, reports=_confirming(t, start, (0, 2))),
                          _now(t))
    delay = max(DELAY, RESTARTED_DELAY_S)
    moved = PassClock(WALL0 + t + delay, SPEED, 30.0)
    assert state.phase is Phase.RESUME_UNCONFIRMED and state.clock == moved
    assert actions == (Publish(moved, PLAN), Log("warning", (
        "the resumed pass waits for the bridge of uav1, which has not confirmed its start: it "
        f"starts in {delay:g} s instead, from 30.00 m past the start line, wall clock "
        f"{moved.start_s:.3f} ({PLAN.label})")))
    # moved later at each instant it is not confirmed by, until start_confirm_wait_s is over
    moves = 1
    while state.phase is Phase.RESUME_UNCONFIRMED:
        t = state.clock.start_s - WALL0 - CONFIRM_MARGIN_S + 0.05
        state, actions = step(state, _seen(t, along, reports=_confirming(t, start, (0, 2))),
                              _now(t))
        moves += state.phase is Phase.RESUME_UNCONFIRMED
    assert t > 1.0 + WAIT and t - delay < 1.0 + WAIT  # the first check past the wait
    assert moves == math.ceil(WAIT / delay)
    assert state.phase is Phase.STARTED and state.awaited is None
    assert state.clock.start_s == pytest.approx(WALL0 + t + CONFIRM_MARGIN_S - 0.05)  # stands
    assert actions == (Log("warning", (
        "the resumed pass starts without its start confirmed by the bridge of uav0, uav1, "
        f"uav2: waited start_confirm_wait_s {WAIT:g} s ({PLAN.label})")),)


def test_a_state_whose_data_disagree_with_its_phase_is_refused():
    with pytest.raises(ValueError):
        StartState(Phase.STARTED, PLAN)  # started, with no start
    with pytest.raises(ValueError):
        StartState(Phase.NO_PLAN, PLAN)


def test_a_bridge_flying_another_speed_is_named_while_the_capture_waits():
    """Its entry, a run-in before the start line, is its speed's: a bridge at 2 m/s under a
    plan at 4.3 m/s holds its UAV where the planner never sees it captured, and says why."""
    state = _planned(t=0.0)
    slow = BridgeReport(1, 1.0, None, "", "", speed_mps=2.0)
    same = BridgeReport(0, 1.0, None, "", "", speed_mps=SPEED)
    along = _waiting({0: 0.0, 2: 0.0}) | {1: run_in_m(SPEED) - run_in_m(2.0) - RUN_IN}
    state, actions = step(state, _seen(1.0, along, reports=(slow, same)), _now(1.0))
    assert state.phase is Phase.AWAITING_CAPTURE and actions == ()
    t = WAIT_LOG_PERIOD_S
    state, actions = step(state, _seen(t, along), _now(t))
    gap = run_in_m(SPEED) - run_in_m(2.0)
    assert _logs(actions) == [("info", (
        f"the pass start waits for uav1 ({gap:.2f} m from its entry; its bridge flies "
        f"speed_mps 2, the plan 4.3 m/s, so its entry is {gap:.2f} m from the one awaited): "
        f"capture_radius_m 1 ({PLAN.label})"))]


def _with_deadline(seen: Observed, timeout_s: float) -> Observed:
    return Observed(seen.poses, seen.speeds, seen.reports, seen.lost, seen.capture_radius_m,
                    seen.start_delay_s, seen.start_confirm_wait_s, seen.bridged, timeout_s)


def test_capture_deadline_leaves_out_the_uav_not_captured_in_one_line():
    """capture_timeout_s after a bridge was first seen, the UAV far from its entry is declared
    lost (its distance said) in one line; the others are not, and the deadline starts again."""
    timeout = 30.0
    state = _planned()
    far = _waiting({0: 0.0, 1: 0.2, 2: -5905.39})
    state, actions = step(state, _with_deadline(_seen(5.0, far), timeout), _now(5.0))
    assert state.capture_since == 5.0 and state.phase is Phase.AWAITING_CAPTURE
    t = 5.0 + timeout  # not yet: the deadline is a strict "after"
    state, actions = step(state, _with_deadline(_seen(t, far), timeout), _now(t))
    assert not [a for a in actions if isinstance(a, DeclareLost)]
    t += 0.1
    state, actions = step(state, _with_deadline(_seen(t, far), timeout), _now(t))
    lost = [a for a in actions if isinstance(a, DeclareLost)]
    assert [a.k for a in lost] == [2]
    assert "5905.39 m from its entry" in lost[0].why and "capture_timeout_s 30" in lost[0].why
    assert lost[0].by == "the pass start"  # (not its bridge's words: the planner's finding)
    (level, text), = _logs(actions)
    assert level == "warning" and text.startswith("the pass start leaves out uav2 (not captured")
    assert "uav0" not in text and "uav1" not in text and PLAN.label in text
    assert state.phase is Phase.AWAITING_CAPTURE and state.capture_since == t
    # lost now (the swarm watch's), the others captured: the pass starts without it
    t += 0.1
    state, actions = step(state, _with_deadline(_seen(t, far, lost=frozenset({2})), timeout),
                          _now(t))
    assert state.phase is Phase.STARTED and isinstance(actions[0], Publish)


def test_capture_deadline_counts_from_the_first_bridge_and_zero_waits_for_ever():
    """No bridge seen (self-flown agents): no deadline; capture_timeout_s 0: none either."""
    state = _planned()
    silent = _waiting({0: 0.0, 1: 0.0})  # uav2 never heard
    for t in (10.0, 500.0):
        state, actions = step(state, _with_deadline(_seen(t, silent, bridged=False), 30.0),
                              _now(t))
        assert actions == () and state.capture_since is None
    state, actions = step(state, _with_deadline(_seen(501.0, silent), 30.0), _now(501.0))
    assert state.capture_since == 501.0
    assert not [a for a in actions if isinstance(a, DeclareLost)]
    t = 540.0
    state, actions = step(state, _with_deadline(_seen(t, silent), 30.0), _now(t))
    assert [(a.k, a.why) for a in actions if isinstance(a, DeclareLost)] == [
        (2, "not captured after capture_timeout_s 30 s: no uav2/mavlink/pose yet")]
    forever = _planned()
    for t in (1.0, 3000.0):
        forever, actions = step(forever, _with_deadline(_seen(t, silent), 0.0), _now(t))
        assert not [a for a in actions if isinstance(a, DeclareLost)]
