"""The hold states and their transitions (mavlink/hold_states.py) as plain values: no rclpy, no
sockets, no mode orders; each test feeds `step` events and reads the states and actions."""
from __future__ import annotations

from uav_insar_planner.mavlink.hold_states import (
    Action,
    FallBack,
    HeardAgain,
    Hold,
    Holds,
    OrderHold,
    OrderResume,
    Plan,
    Rejoin,
    ReleaseHold,
    Seen,
    Silence,
    Tell,
    step,
)

SILENT = "ground station silent for 1.5 s (gcs_timeout_s 1; last heard: gcs/heartbeat)"
BACK = "ground station heard again (gcs/heartbeat) after 3.0 s silent"


def run(holds: Holds, *events) -> tuple[Holds, list[Action]]:
    actions: list[Action] = []
    for event in events:
        holds, more = step(holds, event)
        actions += more
    return holds, actions


def states(holds: Holds) -> list[Hold]:
    return [u.state for u in holds.uavs.values()]


def texts(actions: list[Action]) -> list[str]:
    return [a.text for a in actions if isinstance(a, Tell)]


def seen(*lags: float | None) -> tuple[Seen, ...]:
    return tuple(Seen(k, lag, "LOITER") for k, lag in enumerate(lags))


def start(n: int = 3) -> Holds:
    return Holds.start(range(n), "LOITER", "GUIDED")


def silent(n: int = 3) -> Holds:
    return run(start(n), Silence(SILENT))[0]


def test_silence_holds_every_uav_and_no_rejoin_goes_until_heard():
    holds, _ = run(start(), FallBack(seen(None, 9.0, 0.0), 2.0, "a new pass start"))
    assert states(holds) == [Hold.FLYING, Hold.HELD_BEHIND, Hold.FLYING]
    holds, actions = step(holds, Silence(SILENT))
    assert states(holds) == [Hold.HELD_SILENT] * 3 and holds.silent
    assert holds.uavs[1].behind == ""  # the silence is why now
    assert actions == [OrderHold((0, 1, 2)), Tell(-1, "warn", f"{SILENT}: stopping the "
                                                  "setpoints and commanding LOITER to every "
                                                  "vehicle")]
    assert holds.phase(0) == "holding (LOITER): ground station silent"
    still, actions = step(holds, Rejoin(seen(0.0, 0.0, 0.0), 2.0, "a new plan"))
    assert still == holds and actions == []  # silent: nobody goes back
    holds, actions = step(holds, HeardAgain(BACK))
    assert states(holds) == [Hold.HELD_WAITING] * 3 and not holds.silent
    assert actions == [Tell(-1, "info", BACK)]
    assert holds.phase(2) == ("holding (LOITER): ground station heard again, waiting for the "
                              "pass to resume")


def test_heard_again_a_uav_near_its_target_rejoins_one_far_behind_keeps_holding_once_told():
    holds, _ = run(silent(), HeardAgain(BACK))
    holds, actions = step(holds, Rejoin(seen(1.0, 2.0, 2.01), 2.0, "heard"))
    assert states(holds) == [Hold.FLYING, Hold.FLYING, Hold.HELD_BEHIND]
    assert [a for a in actions if not isinstance(a, Tell)] == [
        ReleaseHold((0,)), OrderResume(0), ReleaseHold((1,)), OrderResume(1)]
    far = ("2.01 m behind its target, more than the 2.00 m it may catch up: cannot keep the "
           "pass, keeps holding")
    assert texts(actions) == [
        "heard: rejoins the pass, 1.00 m behind its target (rejoin limit 2.00 m); LOITER -> "
        "GUIDED",
        "heard: rejoins the pass, 2.00 m behind its target (rejoin limit 2.00 m); LOITER -> "
        "GUIDED",
        f"heard: {far}"]
    assert holds.uavs[2].behind == far and holds.phase(2) == f"holding (LOITER): {far}"
    # the same again: nothing new to tell; closer: it rejoins, its `behind` gone
    assert step(holds, Rejoin(seen(None, None, 2.01), 2.0, "heard"))[1] == []
    holds, actions = step(holds, Rejoin(seen(None, None, 0.3), 2.0, "a new plan"))
    assert states(holds) == [Hold.FLYING] * 3 and holds.uavs[2].behind == ""
    assert holds.phase(2) == ""


def test_a_uav_ahead_of_its_target_rejoins_as_zero_behind():
    holds, actions = run(silent(1), HeardAgain(BACK), Rejoin(seen(-0.4), 2.0, "heard"))
    assert states(holds) == [Hold.FLYING]
    assert "rejoins the pass, 0.00 m behind its target" in texts(actions)[-1]


def test_heard_again_with_a_newer_plan_that_leaves_a_held_uav_out():
    """The bridge waits for the newer plan (no rejoin on hearing); the plan gives uav1 no target:
    it is held again for good, uav0 rejoins with the plan's targets."""
    holds, _ = run(silent(2), HeardAgain(BACK))
    holds, actions = step(holds, Plan(frozenset({0}), flown_before=True))
    assert states(holds) == [Hold.HELD_WAITING, Hold.HELD_NO_TARGET]
    assert actions == [OrderHold((1,)),
                       Tell(-1, "info", "no target in the new plan for uav1: keeps holding")]
    assert holds.phase(1) == ("holding (LOITER) since the ground station fell silent: no target "
                              "in the current plan")
    holds, actions = step(holds, Rejoin(seen(0.5, None), 2.0, "a new plan"))
    assert states(holds) == [Hold.FLYING, Hold.HELD_NO_TARGET]
    assert texts(actions)[-1] == "a new plan: no target in the plan flown: keeps holding"
    assert holds.uavs[1].behind == "no target in the plan flown: keeps holding"
    assert "no target in the current plan" in holds.phase(1)  # the state tells, not `behind`
    # a later plan gives it a target again: held as before, now for its `behind`
    holds, actions = step(holds, Plan(frozenset({0, 1}), flown_before=True))
    assert states(holds) == [Hold.FLYING, Hold.HELD_BEHIND]
    assert actions == [ReleaseHold((0,))]  # only the flying one's hold ends here


def test_a_uav_rejoined_after_a_silence_is_held_by_the_next_plan_without_its_target():
    holds, _ = run(silent(2), HeardAgain(BACK), Rejoin(seen(0.0, 0.0), 2.0, "heard"))
    assert states(holds) == [Hold.FLYING, Hold.FLYING]
    holds, actions = step(holds, Plan(frozenset({0}), flown_before=True))
    assert states(holds) == [Hold.FLYING, Hold.HELD_NO_TARGET]
    assert OrderHold((1,)) in actions
    # once a plan gave it a target, a plan without one is the planner's business, not a hold
    holds, _ = run(silent(2), HeardAgain(BACK), Rejoin(seen(0.0, 0.0), 2.0, "heard"),
                   Plan(frozenset({0, 1}), flown_before=True))
    holds, actions = step(holds, Plan(frozenset({0}), flown_before=True))
    assert states(holds) == [Hold.FLYING, Hold.FLYING] and actions == [ReleaseHold((0,))]


def test_a_plan_during_the_silence_keeps_everyone_held():
    holds, actions = step(silent(2), Plan(frozenset({0}), flown_before=True))
    assert states(holds) == [Hold.HELD_SILENT, Hold.HELD_NO_TARGET] and holds.silent
    assert ReleaseHold((0,)) not in actions  # held: its hold order stays
    holds, _ = step(holds, Plan(frozenset({0, 1}), flown_before=True))
    assert states(holds) == [Hold.HELD_SILENT, Hold.HELD_SILENT]


def test_a_start_heard_late_holds_the_flying_uavs_too_far_behind():
    holds, _ = run(silent(4), HeardAgain(BACK), Rejoin(seen(0.0, 0.0, 0.0, 9.0), 2.0, "heard"))
    assert holds.uavs[3].state is Hold.HELD_BEHIND
    holds, actions = step(holds, FallBack(seen(1.0, 9.0, None, 12.0), 2.0, "a new pass start"))
    assert states(holds) == [Hold.FLYING, Hold.HELD_BEHIND, Hold.FLYING, Hold.HELD_BEHIND]
    assert actions == [OrderHold((1,)), Tell(
        1, "warn", "a new pass start: 9.00 m behind its target, more than the 2.00 m it may "
                   "catch up: cannot keep the pass, keeps holding (LOITER, no sprint)")]
    assert "9.00 m behind" in holds.phase(1)


def test_every_pose_nan_is_the_mission_stop_an_order_for_every_uav():
    holds = start()
    assert step(holds, Plan(frozenset(), flown_before=False)) == (holds, [])  # nothing flown
    after, actions = step(holds, Plan(frozenset(), flown_before=True))
    assert after == holds and states(after) == [Hold.FLYING] * 3  # the plan stops them
    assert actions == [OrderHold((0, 1, 2)), Tell(-1, "warn", "every pose NaN: the mission "
                                                  "stopped; commanding LOITER to every vehicle")]
    # the next plan ends it for the UAVs it gives a target (they stay in LOITER till a pilot)
    assert step(after, Plan(frozenset({0, 2}), flown_before=False))[1] == [ReleaseHold((0, 2))]
    # one already held for a late start: no mission stop order on top
    late, _ = step(holds, FallBack(seen(9.0), 2.0, "late"))
    assert step(late, Plan(frozenset(), flown_before=True))[1] == []


def test_a_uav_a_pilot_switched_out_of_the_hold_is_not_taken_back():
    holds, _ = run(silent(2), HeardAgain(BACK))
    pilot = (Seen(0, 0.5, "STABILIZE", ours=False), Seen(1, 0.5, "GUIDED", ours=True))
    holds, actions = step(holds, Rejoin(pilot, 2.0, "heard"))
    assert states(holds) == [Hold.FLYING, Hold.FLYING]
    assert OrderResume(0) not in actions and OrderResume(1) in actions
    assert ReleaseHold((0,)) in actions  # the bridge's hold order ends either way
    assert texts(actions)[0] == (
        "heard: rejoins the pass, 0.50 m behind its target (rejoin limit 2.00 m); in "
        "STABILIZE, not the LOITER the bridge commanded (a pilot switched it): not taken back "
        "to GUIDED")


def test_a_flying_uav_is_left_alone_by_a_rejoin():
    holds = start(2)
    assert step(holds, Rejoin(seen(50.0, None), 2.0, "a new plan")) == (holds, [])
    assert holds.phase(0) == "" and not Hold.FLYING.held
    assert all(s.held for s in Hold if s is not Hold.FLYING)
