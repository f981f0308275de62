"""The simulated link's fading and the wind on the self-flown agent (real parts, no ROS)."""
import math

import numpy as np
import pytest

from uav_insar_planner.params_file import load_params
from uav_insar_planner.solver.power import schedules
from uav_insar_sim.fading import LinkFading
from uav_insar_sim.mission import Mission
from uav_insar_sim.slots import Phase
from uav_insar_sim.wind import Wind

N = 12
FORMATION = np.array([[-40.0, 60.0], [-35.0, 58.0], [-45.0, 62.0]])


@pytest.fixture(scope="module")
def scenario():
    p = load_params(overrides={"num_slots": N})
    return p, schedules(p, FORMATION, "proposed")


def track(n, step=4.3):
    return [(0.0, i * step, 50.0) for i in range(n)]


def gains(fading, positions):
    return np.array([fading.gain(q) for q in positions])


def test_off_is_exactly_one_and_draws_nothing():
    f = LinkFading(0.0, 20.0, None, seed=5)
    assert f.off and all(g == 1.0 for g in gains(f, track(50)))


def test_fading_is_reproducible_per_seed_and_uav():
    a = gains(LinkFading(4.0, 20.0, 6.0, seed=3, uav_id=1), track(40))
    assert np.array_equal(a, gains(LinkFading(4.0, 20.0, 6.0, seed=3, uav_id=1), track(40)))
    assert not np.array_equal(a, gains(LinkFading(4.0, 20.0, 6.0, seed=4, uav_id=1), track(40)))
    assert not np.array_equal(a, gains(LinkFading(4.0, 20.0, 6.0, seed=3, uav_id=2), track(40)))


def test_rician_power_gain_has_mean_one():
    for k_db in (-3.0, 6.0, 15.0):
        g = gains(LinkFading(0.0, 20.0, k_db, seed=1), track(40000))
        assert g.mean() == pytest.approx(1.0, abs=0.02)
    # A strong line of sight fades less than a weak one.
    spread = [gains(LinkFading(0.0, 20.0, k, seed=2), track(20000)).std() for k in (0.0, 15.0)]
    assert spread[1] < 0.5 * spread[0]


def test_shadowing_is_lognormal_with_the_std_and_decorrelates_with_distance():
    std, corr, step = 4.0, 20.0, 5.0
    runs = np.array([10 * np.log10(gains(LinkFading(std, corr, None, seed=s), track(12, step)))
                     for s in range(3000)])
    assert runs.mean() == pytest.approx(0.0, abs=0.1)
    assert runs.std() == pytest.approx(std, rel=0.03)
    for lag in (1, 4, 10):
        rho = np.corrcoef(runs[:, 0], runs[:, lag])[0, 1]
        assert rho == pytest.approx(math.exp(-lag * step / corr), abs=0.05)


def fly(m, until=300.0, step=0.37):
    t = 0.0
    while m.phase != Phase.DONE and t < until:
        t += step
        m.advance(t)
    return m


def test_wind_off_is_exactly_todays_trajectory(scenario):
    p, power = scenario
    plain = Mission(1, p, 10.0, 3.0)
    plain.set_plan(FORMATION[1], power[1])
    fly(plain)
    calm = Mission(1, p, 10.0, 3.0, wind=Wind((0.0, 0.0, 0.0), 0.0, 2.0, seed=9))
    calm.set_plan(FORMATION[1], power[1])
    fly(calm)
    assert [s.position for s in calm.samples] == [s.position for s in plain.samples]
    assert [s.rate_bps for s in calm.samples] == [s.rate_bps for s in plain.samples]


def test_steady_wind_displaces_the_uav_downwind_and_its_accel_limit_sets_how_far(scenario):
    p, power = scenario

    def offsets(accel, wind=(5.0, 0.0, 0.0), gust=0.0):
        m = Mission(0, p, 10.0, accel, wind=Wind(wind, gust, 2.0, seed=1))
        m.set_plan(FORMATION[0], power[0])
        fly(m)
        assert [s.slot for s in m.samples] == list(range(N)) and m.phase == Phase.DONE
        return np.array([s.position[0] - FORMATION[0, 0] for s in m.samples])

    soft, stiff = offsets(3.0), offsets(6.0)
    assert (soft[-4:] > 1.0).all()  # downwind (+x) of the target at the end of the pass
    assert soft[-1] == pytest.approx(25.0 / 6.0, rel=0.5)  # about |w|^2 / (2 a_max)
    assert stiff[-1] < soft[-1]
    gusty = offsets(3.0, gust=1.5)
    assert np.array_equal(gusty, offsets(3.0, gust=1.5)) and not np.array_equal(gusty, soft)
