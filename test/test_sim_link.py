"""Pure checks of the agent's link model against the paper's FDMA formula."""
import math

import pytest

from uav_insar_planner import model
from uav_insar_planner.params_file import load_params
from uav_insar_sim.radio import achieved_rate


def test_rate_is_the_free_space_fdma_formula():
    # d = 5 m, P beta / d^2 = 2 * 10 / 25 = 0.8
    assert achieved_rate((3.0, 4.0, 0.0), 2.0, (0.0, 0.0, 0.0), 1e6, 10.0) == pytest.approx(
        1e6 * math.log2(1.8))


def test_planned_power_at_the_planned_position_meets_rate_min_exactly():
    p = load_params()
    q = (-40.0, 12.9, 60.0)
    d = model.distance_to_station(*q, p.ground_station)
    power = float(model.power_for_rate(p.rate_min_bps[1], d, p.comm_bandwidth_hz, p.beta_c))
    rate = achieved_rate(q, power, p.ground_station, p.comm_bandwidth_hz, p.beta_c)
    assert rate == pytest.approx(p.rate_min_bps[1], rel=1e-12)
    toward = achieved_rate((-39.0, 13.9, 59.0), power, p.ground_station, p.comm_bandwidth_hz,
                           p.beta_c)
    away = achieved_rate((-41.0, 11.9, 61.0), power, p.ground_station, p.comm_bandwidth_hz,
                         p.beta_c)
    assert away < rate < toward
