"""The planner's reading of the bridges' confirmations of a resumed start
(ros/start_confirmations.py); the processes around it: test_pass_resume.py (the planner,
with bridges played by the test) and test_gcs_processes.py (the real bridge)."""
from __future__ import annotations

import pytest

from uav_insar_planner.ros.start_confirmations import (
    CONFIRM_MARGIN_S,
    CONFIRMED,
    GIVE_UP,
    LATER,
    REPORT_FRESH_S,
    WAIT,
    AwaitedStart,
    reported_number,
    verdict,
)

START_S = 1_800_000_000.0  # wall clock of the awaited instant


WAIT_S = 20.0  # the planner's start_confirm_wait_s


def _awaited(since: float = 100.0) -> AwaitedStart:
    return AwaitedStart(START_S, 5.0, since, WAIT_S)


@pytest.mark.parametrize("value", ["", None, "nan", "inf", "-inf", "1e400", "soon", "1,5"])
def test_a_report_that_is_no_instant_confirms_nothing(value):
    assert reported_number(value) is None


def test_the_instant_as_the_bridge_formats_it_is_read_back():
    assert reported_number(f"{START_S:.3f}") == START_S


def test_nothing_is_decided_before_the_margin_before_the_instant():
    early = START_S - CONFIRM_MARGIN_S - 0.01
    assert verdict(_awaited(), [0, 1, 2], {}, 101.0, early) == (WAIT, [])


def test_every_flown_bridge_with_a_fresh_report_of_the_instant_confirms_it():
    now = 104.0
    reports = {k: (now - 0.5, START_S + 0.0004) for k in (0, 1, 2)}
    assert verdict(_awaited(), [0, 1, 2], reports, now, START_S - 0.2) == (CONFIRMED, [])
    # a UAV that is not flown (lost, or not in the plan) is not waited for
    assert verdict(_awaited(), [0, 2], {0: reports[0], 2: reports[2]}, now,
                   START_S) == (CONFIRMED, [])


def test_a_missing_stale_or_other_instant_moves_the_start_later_naming_those_uavs():
    now = 104.0
    reports = {0: (now - 0.5, START_S),
               1: (now - REPORT_FRESH_S - 0.1, START_S),  # heard, but long ago
               2: (now - 0.5, START_S - 3.0)}  # flies the start before this one
    assert verdict(_awaited(), [0, 1, 2, 3], reports, now, START_S - 0.1) == (LATER, [1, 2, 3])


def test_after_the_longest_wait_the_start_stands_and_the_missing_are_named():
    since = 100.0
    now = since + WAIT_S + 0.1
    got = verdict(_awaited(since), [0, 1], {0: (now, START_S)}, now, START_S)
    assert got == (GIVE_UP, [1])


def test_a_start_moved_later_keeps_its_delay_and_when_the_wait_began():
    moved = _awaited(since=100.0).later(START_S + 2.0)
    assert moved.start_s == pytest.approx(START_S + 7.0)
    assert moved.since == 100.0 and moved.delay_s == 5.0 and moved.wait_s == WAIT_S
