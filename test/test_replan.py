"""Re-planning without ROS: the reduced problem (replanning/plans.py) against the independent
checker, and the re-plan triggers' state machine (replanning/triggers.py) on a clock of the
test's own."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from uav_insar_planner import load_params, model, solve
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.replanning import plans
from uav_insar_planner.replanning.triggers import SATURATED_MISSES, ReplanTriggers
from uav_insar_sim.slots import Phase


@pytest.fixture(scope="module")
def table1():
    p = load_params()
    return p, solve(p)


def reduced_inputs(full, problem):
    """The full plan's rows and slots that the reduced problem covers, as (3, 2), (3, N')."""
    rows, n0 = list(problem.rows), problem.first_slot
    q = np.vstack([full.formation[rows], [[np.nan, np.nan]]])
    power = np.vstack([full.p_com_w[rows, n0:], np.zeros((1, full.p_com_w.shape[1] - n0))])
    return q, power


@pytest.mark.parametrize("lost,survivor", [(1, 2), (2, 1)])
def test_lost_slave_gives_a_feasible_single_baseline_plan_for_the_slots_left(
        table1, lost, survivor):
    p, plan = table1
    n0 = 30
    energy = {k: plans.energy_left_j(p, plan.p_com_w, k, n0) for k in range(3)}
    full, problem = plans.replan_without(p, plan.p_com_w, lost, (survivor,), n0, energy)
    assert full.feasible and full.scheme == "single-baseline"
    assert full.active_uavs == [0, survivor]
    assert np.isnan(full.formation[lost]).all()
    assert (full.p_com_w[lost] == 0).all()
    # Past slots keep what was flown; the slots left are the reduced problem's answer.
    assert full.p_com_w[[0, survivor], :n0] == pytest.approx(plan.p_com_w[[0, survivor], :n0])
    q, power = reduced_inputs(full, problem)
    ev = evaluate(problem.params, q, power, "single-baseline")
    assert ev.feasible, ev.violated
    assert ev.sigma_h == pytest.approx(full.sigma_h_m)
    # The rate the survivor needs is its own, met on the mission's own track slots n0..N-1.
    x, z = full.formation[survivor]
    d = model.distance_to_station(x, p.y_track[n0:], z, p.ground_station)
    rate = model.fdma_rate(full.p_com_w[survivor, n0:], d, p.comm_bandwidth_hz, p.beta_c)
    assert rate.min() >= p.rate_min_bps[survivor] * (1 - 1e-6)
    # Each UAV within the energy it had left (C11 per UAV).
    for k in (0, survivor):
        assert full.p_com_w[k, n0:].sum() * p.slot_duration_s <= energy[k] * (1 + 1e-9)
    assert set(full.metrics["pairs"]) == {f"uav{survivor}"}
    assert f"from slot {n0} without uav{lost}" in full.message


def test_a_survivor_short_of_energy_is_held_to_it(table1):
    p, plan = table1
    n0 = 40
    energy = {0: plans.energy_left_j(p, plan.p_com_w, 0, n0), 1: 60.0, 2: 0.0}
    full, problem = plans.replan_without(p, plan.p_com_w, 2, (1,), n0, energy)
    assert problem.params.energy_budget_j(1) == 60.0
    if full.feasible:
        assert full.p_com_w[1, n0:].sum() * p.slot_duration_s <= 60.0 * (1 + 1e-9)
        # The same spot would have cost more: the budget moved the slave closer to the station.
        x, z = plan.formation[1]
        need = model.power_for_rate(p.rate_min_bps[1], model.distance_to_station(
            x, p.y_track[n0:], z, p.ground_station), p.comm_bandwidth_hz, p.beta_c)
        assert need.sum() * p.slot_duration_s > 60.0
    else:
        assert "C11" in full.blocking_constraints


def test_reduced_problem_refuses_the_master_a_past_slot_or_no_energy(table1):
    p, plan = table1
    energy = {0: 100.0, 1: 100.0, 2: 100.0}
    for args in ((0, (1,), 10, energy), (1, (2,), 80, energy), (1, (2,), -1, energy),
                 (1, (2,), 10, {**energy, 2: 0.0}), (1, (), 10, energy),
                 (1, (1, 2), 10, energy)):
        with pytest.raises(ValueError, match=r"^(lost|first_slot|energy_left): value "):
            plans.remaining_problem(p, *args)


def test_the_shifted_station_is_exact(table1):
    p, _ = table1
    problem = plans.remaining_problem(p, 2, (1,), 25, {0: 300.0, 1: 300.0})
    r = problem.params
    assert r.num_slots == p.num_slots - 25
    assert (r.y_track - r.ground_station[1]) == pytest.approx(p.y_track[25:]
                                                              - p.ground_station[1])


def test_power_replan_keeps_the_formation_and_the_energy_left(table1):
    p, plan = table1
    n0, left = 50, 40.0
    new = plans.power_replan(p, plan, 1, n0, left, gain=10 ** -0.6)
    assert np.array_equal(new.formation, plan.formation, equal_nan=True)
    assert new.p_com_w[:, :n0] == pytest.approx(plan.p_com_w[:, :n0])
    assert new.p_com_w[[0, 2]] == pytest.approx(plan.p_com_w[[0, 2]])
    assert new.p_com_w[1, n0:].max() <= p.p_max_w
    assert new.p_com_w[1, n0:].sum() * p.slot_duration_s == pytest.approx(left)
    # Enough energy: exactly the model's need over the measured 6 dB loss (below P_max).
    rich = plans.power_replan(p, plan, 2, n0, 500.0, gain=10 ** -0.6)
    assert rich.p_com_w[2, n0:] == pytest.approx(
        np.minimum(plan.p_com_w[2, n0:] * 10 ** 0.6, p.p_max_w))


def test_measured_gain_inverts_the_rate_model(table1):
    p, plan = table1
    q = (plan.formation[1, 0], 10.0, plan.formation[1, 1])
    d = model.distance_to_station(*q, p.ground_station)
    rate = model.fdma_rate(2.0, d, p.comm_bandwidth_hz, p.beta_c * 0.25)
    assert plans.measured_gain(p, 1, q, 2.0, float(rate)) == pytest.approx(0.25)


def test_hold_plan_is_all_nan_and_no_power(table1):
    p, _ = table1
    hold = plans.hold_plan(p, "why")
    assert np.isnan(hold.formation).all() and not hold.p_com_w.any()
    assert hold.active_uavs == [] and hold.p_com_w.shape == (3, p.num_slots)


# --- the triggers ----------------------------------------------------------------------------
def heard(m, k, t, slot=None, left=500.0, power=1.0, rate=None):
    m.heard_pose(k, t, (0.0, 0.0, 50.0))
    if slot is not None:
        m.heard_rate(k, t, m.params.rate_min_bps[k] if rate is None else rate)
        m.heard_offload(k, t, slot, power, left)


def test_silence_past_the_timeout_is_lost_once_with_the_slot_reached(table1):
    p, plan = table1
    m = ReplanTriggers(p)
    m.set_plan(plan.p_com_w)
    for k in range(3):
        heard(m, k, 0.0, slot=4)
    heard(m, 0, 4.0, slot=9)
    heard(m, 2, 4.0, slot=9, left=123.0)
    assert m.check(4.9, 5.0) == []
    lost = m.check(5.1, 5.0)
    assert [(x.uav, x.slot) for x in lost] == [(1, 10)]
    assert "no pose, rate or offload for 5.1 s" in lost[0].why
    assert m.check(9.0, 5.0) == []  # reported once; uav0 and uav2 still heard at 4.0
    assert m.energy_left_j(2, 10) == 123.0
    assert m.energy_left_j(1, 10) == 500.0  # its last report
    assert m.next_slot() == 10
    heard(m, 1, 9.5)
    assert "heard again since" in m.describe(1, 9.6)
    assert 1 in m.lost  # lost stays lost


def test_without_offload_reports_the_slot_comes_from_the_poses(table1):
    p, _ = table1
    m = ReplanTriggers(p)
    assert m.next_slot() == 0
    step = p.speed * p.slot_duration_s
    m.heard_pose(0, 0.0, (0.0, -3.0, 50.0))  # on the run-up
    assert m.next_slot() == 0
    m.heard_pose(2, 0.0, (0.0, 7.5 * step, 50.0))  # slot 7 started
    assert m.next_slot() == 8


def test_never_heard_is_never_lost(table1):
    p, _ = table1
    m = ReplanTriggers(p)
    assert m.check(1000.0, 5.0) == []
    assert m.describe(0, 1000.0) == "not heard yet"
    heard(m, 2, 1000.0)
    assert [x.uav for x in m.check(1006.0, 5.0)] == [2]


def test_bridge_lost_report_is_lost_at_once(table1):
    p, _ = table1
    m = ReplanTriggers(p)
    heard(m, 0, 0.0, slot=3)
    lost = m.bridge_lost(1, 0.5, "lost: no heartbeat for 5.0 s")
    assert lost.uav == 1 and lost.slot == 4 and lost.why.startswith("MAVLink bridge: ")
    assert m.bridge_lost(1, 0.6, "again") is None


def test_energy_left_without_offload_reports_is_the_plans_schedule(table1):
    p, plan = table1
    m = ReplanTriggers(p)
    m.set_plan(plan.p_com_w)
    assert m.energy_left_j(1, 20) == pytest.approx(
        p.e_max_j - plan.p_com_w[1, :20].sum() * p.slot_duration_s)


def test_three_saturated_misses_in_a_row_warn_once(table1):
    p, plan = table1
    m = ReplanTriggers(p)
    m.set_plan(plan.p_com_w)
    low = p.rate_min_bps[1] * 0.5
    heard(m, 1, 0.0, slot=0, power=p.p_max_w, rate=low)
    heard(m, 1, 0.1, slot=1, power=p.p_max_w, rate=low)
    heard(m, 1, 0.2, slot=2, power=p.p_max_w * 0.5, rate=low)  # not saturated: count restarts
    for n in range(3, 3 + SATURATED_MISSES - 1):
        heard(m, 1, 0.1 * n, slot=n, power=p.p_max_w, rate=low)
    assert m.take_saturated() == []
    heard(m, 1, 1.0, slot=5, power=p.p_max_w, rate=low, left=77.0)
    events = m.take_saturated()
    assert len(events) == 1 and events[0].uav == 1 and events[0].slots == (3, 4, 5)
    assert events[0].next_slot == 6 and events[0].energy_left_j == 77.0 and events[0].at_p_max
    assert 0.0 < events[0].gain < 1.0
    assert m.take_saturated() == []


def test_short_of_energy_counts_as_saturated_and_met_rates_do_not(table1):
    p, plan = table1
    m = ReplanTriggers(p)
    m.set_plan(plan.p_com_w)
    low = p.rate_min_bps[0] * 0.9
    for n in range(SATURATED_MISSES):  # well below P_max, but no energy left for the plan
        heard(m, 0, 0.1 * n, slot=n, power=0.5, rate=low, left=1.0)
    events = m.take_saturated()
    assert len(events) == 1 and not events[0].at_p_max
    for n in range(10, 10 + SATURATED_MISSES):  # at P_max but R_min met: fine
        heard(m, 0, 0.1 * n, slot=n, power=p.p_max_w)
    assert m.take_saturated() == []


def test_a_new_plan_restarts_the_count(table1):
    p, plan = table1
    m = ReplanTriggers(p)
    m.set_plan(plan.p_com_w)
    low = p.rate_min_bps[1] * 0.5
    for n in range(SATURATED_MISSES - 1):
        heard(m, 1, 0.1 * n, slot=n, power=p.p_max_w, rate=low)
    m.set_plan(dataclasses.replace(plan).p_com_w)
    heard(m, 1, 1.0, slot=SATURATED_MISSES - 1, power=p.p_max_w, rate=low)
    assert m.take_saturated() == []


# --- the agent's side: a NaN target in mid-flight is a hold ----------------------------------
def test_a_nan_target_in_mid_flight_holds_and_flies_no_more_slots(table1):
    from uav_insar_sim.mission import Mission

    p, plan = table1
    m = Mission(1, p, 10.0, 3.0)
    m.set_plan(tuple(plan.formation[1]), plan.p_com_w[1])
    t = 0.0
    while len(m.samples) < 5:
        t += 0.5
        m.advance(t)
    m.set_plan((np.nan, np.nan), np.zeros(p.num_slots))
    assert m.phase == Phase.HOLD
    flown = len(m.samples)
    m.advance(t + 5.0)  # brakes from 4.3 m/s at 3 m/s^2: at rest within 1.5 s
    here = m.state.position.copy()
    assert not m.state.velocity.any()
    m.advance(t + 60.0)
    assert len(m.samples) == flown and np.array_equal(m.state.position, here)
    m.set_plan(tuple(plan.formation[1]), plan.p_com_w[1])  # hold is final
    assert m.phase == Phase.HOLD
    idle = Mission(2, p, 10.0, 3.0)
    idle.set_plan((np.nan, np.nan), np.zeros(p.num_slots))
    assert idle.phase == Phase.IDLE  # not flown from the start: idle, as before
