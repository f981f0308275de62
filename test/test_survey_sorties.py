"""Sorties (survey/sorties.py): strips grouped in flight order, each sortie within its budget
and never shorter than its strips flown at v_y; a strip that fits no battery is refused."""
from __future__ import annotations

import math

import pytest

from uav_insar_planner.survey.sorties import (
    FlightSpeeds,
    plan_sorties,
    sortie_of,
    strip_starts_s,
)
from uav_insar_planner.track.passes import TrackPass, min_run_in_m, run_out_m
from uav_insar_planner.track.speed_profile import RAMP_MPS2

V, LENGTH, SPACING, HEIGHT = 4.3, 200.0, 40.0, 60.0
RUN_IN = min_run_in_m(V) + 2.0


def _strips(count: int) -> list[TrackPass]:
    """Boustrophedon: strip i at x = 100 + i * SPACING, from y = 300, alternating."""
    return [TrackPass(100.0 + i * SPACING, 300.0 if i % 2 == 0 else 300.0 + LENGTH, LENGTH,
                      1 if i % 2 == 0 else -1, RUN_IN) for i in range(count)]


def test_strips_go_in_order_into_sorties_that_fit_the_budget():
    strips, fly = _strips(5), FlightSpeeds()
    two = sortie_of(strips, [0, 1], HEIGHT, V, fly).flight_time_s
    three = sortie_of(strips, [0, 1, 2], HEIGHT, V, fly).flight_time_s
    budget = 0.5 * (two + three)
    sorties = plan_sorties(strips, HEIGHT, V, budget, fly)
    assert [s.strips for s in sorties] == [(0, 1), (2, 3), (4,)]
    for s in sorties:
        assert s.flight_time_s <= budget
        assert s.strips_s >= len(s.strips) * LENGTH / V  # never faster than v_y on a strip
        assert s.climb_s == pytest.approx(HEIGHT / fly.climb_mps)
        assert s.descent_s == pytest.approx(HEIGHT / fly.descent_mps)
    # out to strip 2's entry, back from strip 3's stop (both beyond y = 300 m)
    assert sorties[1].transit_s == pytest.approx(
        math.dist((0.0, 0.0), strips[2].entry) / fly.transit_mps)
    assert sorties[1].return_s == pytest.approx(
        math.dist(strips[3].stop(V), (0.0, 0.0)) / fly.transit_mps)
    # each strip starts once the one before has stopped, the turn is flown and it settled
    starts = strip_starts_s(strips, sorties[0], V, fly)
    assert starts[0] == pytest.approx(sorties[0].climb_s + sorties[0].transit_s + fly.settle_s)
    turn = math.dist(strips[0].stop(V), strips[1].entry) / fly.transit_mps
    # run-in, strip and run-out at v_y, and half of v/a lost to the ramp and to the brake each
    stop0 = starts[0] + (RUN_IN + LENGTH + run_out_m(V)) / V + V / RAMP_MPS2
    assert starts[1] == pytest.approx(stop0 + turn + fly.settle_s, abs=1e-6)
    # a bigger battery takes them all at once
    assert [s.strips for s in plan_sorties(strips, HEIGHT, V, 1e6, fly)] == [(0, 1, 2, 3, 4)]


def test_a_strip_that_fits_no_battery_is_refused_in_one_line():
    strips = _strips(2)
    alone = sortie_of(strips, [0], HEIGHT, V, FlightSpeeds()).flight_time_s
    with pytest.raises(ValueError) as err:
        plan_sorties(strips, HEIGHT, V, 0.9 * alone)
    text = str(err.value)
    assert text.startswith("endurance_min: value ") and "\n" not in text
    assert f"{alone / 60.0:.3g} min" in text


@pytest.mark.parametrize("field", ["climb_mps", "descent_mps", "transit_mps", "settle_s"])
def test_bad_flight_speeds_are_refused_naming_the_field(field):
    with pytest.raises(ValueError) as err:
        FlightSpeeds(**{field: -1.0})
    assert str(err.value).startswith(f"{field}: value -1.0 is not allowed")
