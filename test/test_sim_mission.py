"""Pure checks of one agent's mission: phases, slot timing, rates, noise, replanning."""
import numpy as np
import pytest

from uav_insar_planner.evaluate import FEAS_TOL
from uav_insar_planner.params_file import load_params
from uav_insar_planner.schemes import planned_rate_bps
from uav_insar_planner.solver.power import schedules
from uav_insar_sim.mission import Mission
from uav_insar_sim.slots import Phase

N = 12
FORMATION = np.array([[-40.0, 60.0], [-35.0, 58.0], [-45.0, 62.0]])


@pytest.fixture(scope="module")
def scenario():
    p = load_params(overrides={"num_slots": N})
    return p, schedules(p, FORMATION, "proposed")


def fly(mission, until=300.0, step=0.37):
    phases, t = [mission.phase], mission.t
    while mission.phase != Phase.DONE and t < until:
        t += step
        mission.advance(t)
        if mission.phase != phases[-1]:
            phases.append(mission.phase)
    mission.advance(t + 20.0)  # brake to a hover
    return phases


@pytest.mark.parametrize("k", [0, 1, 2])
def test_noise_free_mission_flies_every_slot_on_the_model_grid_at_the_planned_rate(scenario, k):
    p, power = scenario
    m = Mission(k, p, max_speed=10.0, max_accel=3.0)
    assert m.advance(5.0) == [] and m.phase == Phase.WAIT
    m.set_plan(FORMATION[k], power[k])
    assert fly(m) == [Phase.TRANSIT, Phase.TRACK, Phase.DONE]
    assert [s.slot for s in m.samples] == list(range(N))
    for n, s in enumerate(m.samples):
        assert s.position == pytest.approx((FORMATION[k, 0], p.y_track[n], FORMATION[k, 1]),
                                           abs=1e-9)
        assert s.power_w == power[k, n]
        # the plan's rate margin exactly: (1 + rate_margin) R_min,k, no more, no less
        assert abs(s.rate_bps - planned_rate_bps(p, k, "proposed")) <= FEAS_TOL * max(
            p.rate_min_bps)
        assert s.margin_bps == pytest.approx(p.rate_margin * p.rate_min_bps[k], rel=1e-6)
    assert not m.state.velocity.any()


def test_position_noise_shrinks_the_margin_reproducibly(scenario):
    p, power = scenario

    def margins(std, seed):
        m = Mission(1, p, 10.0, 3.0, noise_std=std, noise_seed=seed)
        m.set_plan(FORMATION[1], power[1])
        fly(m)
        return np.array([s.margin_bps for s in m.samples])

    clean, noisy = margins(0.0, 0), margins(2.0, 7)
    assert len(noisy) == N
    assert noisy.min() < clean.min() - 1e4  # some slots miss R_min by > 10 kbit/s
    assert noisy.mean() < clean.mean()  # |q + e - g|^2 grows by 3 std^2 on average
    assert np.array_equal(noisy, margins(2.0, 7))


def test_replan_during_the_track_retargets_without_restarting_the_slots(scenario):
    p, power = scenario
    m = Mission(2, p, 10.0, 3.0)
    m.set_plan(FORMATION[2], power[2])
    t = 0.0
    while len(m.samples) < 4:
        t += 0.25
        m.advance(t)
    m.set_plan((-44.0, 61.0), power[2])
    fly(m)
    assert [s.slot for s in m.samples] == list(range(N))
    assert m.samples[-1].position[0] == pytest.approx(-44.0)
    assert m.samples[-1].position[2] == pytest.approx(61.0)


def test_unflown_uav_stays_idle_and_slow_agents_are_refused(scenario):
    p, power = scenario
    m = Mission(2, p, 10.0, 3.0)
    m.set_plan((float("nan"), float("nan")), power[2])
    m.advance(100.0)
    assert m.phase == Phase.IDLE and m.samples == []
    with pytest.raises(ValueError, match="max_speed_mps"):
        Mission(0, p, max_speed=p.speed / 2, max_accel=3.0)
