"""The one pass clock (track/pass_clock.py): its target and its inverse agree, whatever the
start (from the hover, joined, resumed mid-track, braked at its end), and the same start is
one rule for every reader."""
from __future__ import annotations

import math

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from uav_insar_planner.track.capture import outside
from uav_insar_planner.track.pass_clock import (
    JOIN_GRACE_S,
    SAME_LINE_M,
    SAME_START_S,
    PassClock,
)
from uav_insar_planner.track.speed_profile import BRAKE_MPS2, RAMP_MPS2, ramp_delay_s

clocks = st.builds(PassClock, start_s=st.floats(-100.0, 100.0),
                   speed_mps=st.floats(0.5, 15.0), offset_m=st.floats(0.0, 50.0),
                   duration_s=st.one_of(st.just(0.0), st.floats(30.0, 200.0)),
                   ramp=st.booleans())


@settings(max_examples=300, deadline=None)
@given(clock=clocks, ahead=st.floats(0.0, 300.0))
def test_time_at_is_the_inverse_of_the_target_along_track(clock, ahead):
    """Past its resume point, the target is where `time_at` says it is, when it says (a
    pass resumes before its braking, never in it)."""
    v = clock.speed_mps
    assume(clock.duration_s == 0.0 or clock.offset_m < v * clock.duration_s - v * v / BRAKE_MPS2)
    d = clock.offset_m + ahead
    t = clock.time_at(d)
    if math.isinf(t):  # beyond the end of a finite pass: the target stops short of it
        assert d >= clock.along(1e9)[0] - 1e-6
        return
    assert t >= clock.start_s - 1e-9
    assert clock.along(t)[0] == pytest.approx(d, abs=1e-6)
    # and no earlier: the target only moves forward
    assert clock.along(t - 1e-3)[0] <= d + 1e-9


def test_from_the_hover_the_target_ramps_up_then_runs_behind_the_unramped_clock():
    v = 4.3
    ramped, joined = PassClock(10.0, v), PassClock(10.0, v, ramp=False)
    assert ramped.along(9.0) == (0.0, 0.0)  # holds at the line until its instant
    assert ramped.along(11.0) == pytest.approx((0.5 * RAMP_MPS2, RAMP_MPS2))
    late = 30.0
    assert ramped.along(late)[0] == pytest.approx(joined.along(late)[0] - v * ramp_delay_s(v))
    # the slot lines: 1 s apart once cruising, the first ones later by the ramp
    lines = [ramped.time_at(n * v) for n in range(6)]
    assert lines[0] == 10.0 and lines[1] == pytest.approx(10.0 + math.sqrt(2 * v / RAMP_MPS2))
    assert lines[5] - lines[4] == pytest.approx(1.0)
    assert joined.time_at(2 * v) == pytest.approx(12.0)


def test_a_resumed_pass_counts_its_lines_from_where_it_would_have_left_the_start_line():
    v, offset = 4.0, 20.0
    resumed = PassClock(100.0, v, offset_m=offset)
    assert resumed.along(99.0) == (offset, 0.0)  # holds at its offset until the instant
    assert resumed.origin_s() == pytest.approx(100.0 - offset / v)
    assert resumed.time_at(offset) == 100.0
    joined = PassClock(100.0, v, offset_m=offset, ramp=False)
    assert joined.time_at(offset + 8.0) == pytest.approx(102.0)


def test_the_same_start_is_one_rule_for_every_reader():
    a = PassClock(1796000012.0, 4.3, 20.0)
    assert a.same_start(PassClock(a.start_s + 0.4 * SAME_START_S, 4.3, 20.0, ramp=False))
    assert not a.same_start(PassClock(a.start_s + 2 * SAME_START_S, 4.3, 20.0))
    assert not a.same_start(PassClock(a.start_s, 4.3, 20.0 + 2 * SAME_LINE_M))
    assert not a.same_start(None)
    # on the bridge's monotonic clock it is the same pass, later or earlier by the clocks'
    # difference, and not the same start as sent
    mono = a.shifted(-1796000000.0)
    assert mono.along(12.5) == a.along(1796000012.5) and not a.same_start(mono)


def test_a_start_heard_late_joins_the_running_pass_and_says_so():
    early = PassClock.heard(100.0, 98.0, 4.3, 20.0)
    assert early.ramp and early.describe(98.0) == (
        "in 2.00 s, wall clock 100.000, resuming 20.00 m past the start line")
    assert PassClock.heard(100.0, 100.0 + 0.9 * JOIN_GRACE_S, 4.3).ramp
    late = PassClock.heard(100.0, 103.0, 4.3)
    assert not late.ramp and late.describe(103.0) == (
        "3.00 s ago (joining the pass), wall clock 100.000")


def test_captured_within_the_radius_and_never_with_a_nan_position():
    start = (1.0, 0.0, 40.0)
    assert outside((1.5, 0.0, 40.0), start, 1.0) is None
    assert outside((3.0, 0.0, 40.0), start, 1.0) == pytest.approx(2.0)
    assert outside((math.nan, 0.0, 40.0), start, 1.0) is not None
    assert outside((300.0, 0.0, 40.0), start, 0.0) is None  # radius 0: captured anywhere
