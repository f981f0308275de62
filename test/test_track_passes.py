"""A mission's passes on one time line (track/passes.py): with its run-in every slot of a pass
is flown at v_y, the first and the last included, in either direction, and each pass starts
when the one before has stopped and the transit is flown."""
from __future__ import annotations

import math

import numpy as np
import pytest

from uav_insar_planner.track.passes import (
    MissionPasses,
    TrackPass,
    min_run_in_m,
    run_out_m,
)

V, SLOT_S, SLOTS = 4.3, 1.0, 20
LENGTH = V * SLOT_S * SLOTS  # 86 m


def _slot_speeds(track: TrackPass, clock) -> list[float]:
    """Each slot's mean along-track speed, line to line, by the clock."""
    lines = [clock.time_at(n * V * SLOT_S) for n in range(SLOTS + 1)]
    return [V * SLOT_S / (b - a) for a, b in zip(lines, lines[1:], strict=False)]


def _lawnmower(run_in: float) -> MissionPasses:
    there = TrackPass(0.0, 0.0, LENGTH, 1, run_in)
    back = TrackPass(-30.0, LENGTH, LENGTH, -1, run_in)  # the next strip, flown the other way
    return MissionPasses((there, back), V, transit_mps=5.0)


def test_with_its_run_in_every_slot_is_flown_at_v_y_and_without_it_slot_0_is_not():
    mission = _lawnmower(min_run_in_m(V) + 1.0)
    for track, clock in zip(mission.passes, mission.schedule(100.0), strict=True):
        assert _slot_speeds(track, clock) == pytest.approx([V] * SLOTS)
        assert clock.along(clock.time_at(0.0))[1] == pytest.approx(V)  # at slot 0's line
        # it holds at its entry until its instant, and stops its run-out past the end
        assert track.point(clock.along(clock.start_s - 1.0)[0]) == track.entry
        stopped = clock.along(track.stop_s(clock) + 5.0)
        assert stopped[1] == 0.0 and stopped[0] == pytest.approx(LENGTH + run_out_m(V))
    # from the hover at the start line (the one pass of old): slot 0 is flown accelerating
    short = _lawnmower(0.0)
    speeds = _slot_speeds(short.passes[0], short.schedule(0.0)[0])
    assert speeds[0] < 0.5 * V and speeds[1] < V  # (the ramp takes 6.2 m at 4.3 m/s)
    assert speeds[2:] == pytest.approx([V] * (SLOTS - 2))


def test_each_pass_starts_when_the_one_before_stopped_and_the_transit_is_flown():
    run_in = min_run_in_m(V) + 1.0
    mission = _lawnmower(run_in)
    there, back = mission.passes
    (transit,) = mission.transits()
    # from the stop of the first, beyond y = 86 m, to the entry of the second, run_in beyond
    assert transit.start == pytest.approx((0.0, LENGTH + run_out_m(V)))
    assert back.entry == pytest.approx((-30.0, LENGTH + run_in))
    assert transit.length_m == pytest.approx(math.hypot(30.0, run_in - run_out_m(V)))
    first, second = mission.schedule(1000.0)
    assert second.start_s == pytest.approx(there.stop_s(first) + transit.length_m / 5.0)
    assert there.stop_s(first) > first.time_at(LENGTH) > first.start_s
    assert mission.duration_s() == pytest.approx(back.stop_s(second) - 1000.0)
    # flown back along -y: its slot n's line is at y = 86 - n v dt
    assert back.point(3 * V * SLOT_S) == pytest.approx((-30.0, LENGTH - 3 * V * SLOT_S))


@pytest.mark.parametrize(("make", "field"), [
    (lambda: TrackPass(0.0, 0.0, 10.0, direction=0), "direction"),
    (lambda: TrackPass(0.0, 0.0, -1.0), "length_m"),
    (lambda: TrackPass(0.0, 0.0, 10.0, run_in_m=math.nan), "run_in_m"),
    (lambda: MissionPasses((), V, 5.0), "passes"),
    (lambda: MissionPasses((TrackPass(0.0, 0.0, 1.0),), V, 0.0), "transit_mps"),
    (lambda: MissionPasses((TrackPass(0.0, 0.0, 1.0),), math.inf, 5.0), "speed_mps"),
])
def test_a_bad_pass_is_refused_in_one_line_naming_the_field(make, field):
    with pytest.raises(ValueError) as err:
        make()
    assert str(err.value).startswith(f"{field}: value ") and "\n" not in str(err.value)


@pytest.mark.parametrize("speed", [1.3, 4.3, 7.7])
def test_every_pass_stops_in_finite_time_whatever_its_length(speed):
    """Its stop is the braked end itself, which rounding must not put out of reach (a strip
    of 86.0 m once took 'inf min')."""
    for length in [0.0, 1e-3, 86.0, *np.linspace(0.1, 900.0, 211)]:
        track = TrackPass(0.0, 0.0, float(length), run_in_m=min_run_in_m(speed) + 2.0)
        clock = track.clock(0.0, speed)
        stop = track.stop_s(clock)
        assert math.isfinite(stop) and clock.along(stop)[1] == pytest.approx(0.0, abs=1e-6)
