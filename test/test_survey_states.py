"""The planner's survey run as a pure state machine (ros/survey_states.py), without rclpy:
strips in order, turns, the return after each sortie, the operator's next sortie, and an
interrupted strip flown again, never counted as flown."""
from __future__ import annotations

from uav_insar_planner.ros.survey_states import (
    Begin,
    Fly,
    Interrupted,
    NextSortie,
    Phase,
    Reply,
    Started,
    SurveyFlight,
    SurveyState,
    Tick,
    step,
)
from uav_insar_planner.track.leg import over_at
from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_planner.track.passes import run_in_m

SPEED = 4.0
SURVEY = SurveyFlight(sorties=((0, 1, 2), (3,)), lengths_m={0: 80.0, 1: 60.0, 2: 80.0, 3: 40.0})


def flies(actions) -> list[Fly]:
    return [a for a in actions if isinstance(a, Fly)]


def fly_strip(state: SurveyState, t0: float) -> tuple[SurveyState, tuple, float]:
    """Start the current strip at t0 and run the clock until just past its end."""
    clock = PassClock(t0, SPEED, -run_in_m(SPEED))
    state, _ = step(state, Started(clock), SURVEY)
    assert state.phase is Phase.STRIP
    end = over_at(clock, SURVEY.lengths_m[state.current])
    state_before, actions = step(state, Tick(end - 0.05), SURVEY)
    assert state_before.phase is Phase.STRIP and not actions, "over before its end"
    state, actions = step(state, Tick(end + 0.05), SURVEY)
    return state, actions, end


def test_a_survey_flies_its_strips_in_order_returns_and_waits_for_the_operator():
    state, actions = step(SurveyState(), Begin(), SURVEY)
    assert state.phase is Phase.TRANSIT and flies(actions) == [Fly(0, 0, 1, False)]
    state, actions, t = fly_strip(state, 100.0)
    assert state.phase is Phase.TURN and flies(actions) == [Fly(1, 0, 1, False)]
    state, actions, t = fly_strip(state, t + 20.0)
    assert flies(actions) == [Fly(2, 0, 1, True)], "the sortie's last strip is marked"
    state, actions, t = fly_strip(state, t + 20.0)
    assert state.phase is Phase.RETURN and not flies(actions) and state.flown == (0, 1, 2)
    # the operator is refused while a sortie flies, accepted once it is over
    state, actions = step(state, NextSortie(), SURVEY)
    assert state.phase is Phase.TRANSIT and flies(actions) == [Fly(3, 1, 1, True)]
    assert [a.ok for a in actions if isinstance(a, Reply)] == [True]
    _, refused = step(state, NextSortie(), SURVEY)
    assert [a.ok for a in refused if isinstance(a, Reply)] == [False]
    state, actions, _ = fly_strip(state, t + 600.0)
    assert state.phase is Phase.DONE and state.flown == (0, 1, 2, 3)
    _, refused = step(state, NextSortie(), SURVEY)
    assert "every sortie is flown" in refused[0].text


def test_nothing_moves_before_the_start_nor_without_one():
    state, _ = step(SurveyState(), Begin(), SURVEY)
    assert step(state, Tick(1e12), SURVEY)[0] == state, "no strip ends before it started"
    state2, actions = step(state, Begin(), SURVEY)
    assert state2 == state and not actions, "begun once"


def test_an_interrupted_strip_is_flown_again_at_once_as_a_new_attempt():
    state, _ = step(SurveyState(), Begin(), SURVEY)
    state, _ = step(state, Started(PassClock(100.0, SPEED, -run_in_m(SPEED))), SURVEY)
    state, said = step(state, Interrupted("uav2 lost"), SURVEY)
    assert "uav2 lost" in said[0].text
    state, actions = step(state, Tick(1e6), SURVEY)
    assert flies(actions) == [Fly(0, 0, 2, False)] and state.flown == ()
    state, actions, _ = fly_strip(state, 2e6)
    assert flies(actions) == [Fly(1, 0, 1, False)] and state.flown == (0,)


def test_an_interrupted_last_strip_goes_first_in_the_next_sortie_or_one_of_its_own():
    state, _ = step(SurveyState(), Begin(), SURVEY)
    t = 100.0
    for _ in range(2):
        state, _, t = fly_strip(state, t + 10.0)
    state, _ = step(state, Started(PassClock(t + 10.0, SPEED, -run_in_m(SPEED))), SURVEY)
    state, _ = step(state, Interrupted("a hold"), SURVEY)
    state, _ = step(state, Tick(1e6), SURVEY)
    assert state.phase is Phase.RETURN and state.flown == (0, 1)
    state, actions = step(state, NextSortie(), SURVEY)
    assert flies(actions) == [Fly(2, 1, 2, False)], "strip 2 again, then strip 3"
    state, actions, _ = fly_strip(state, 2e6)
    assert flies(actions) == [Fly(3, 1, 1, True)]
    state, _ = step(state, Started(PassClock(3e6, SPEED, -run_in_m(SPEED))), SURVEY)
    state, _ = step(state, Interrupted("uav1 lost"), SURVEY)
    state, _ = step(state, Tick(4e6), SURVEY)
    assert state.phase is Phase.RETURN, "no sortie was left: one of its own"
    state, actions = step(state, NextSortie(), SURVEY)
    assert flies(actions) == [Fly(3, 2, 2, True)]
