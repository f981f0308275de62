"""track/cross_track.py: the setpoint moved against the autopilot's tracking error, within its
bounds; closed around a soft simulated position loop with a slow push, it holds the error far
below what the loop alone holds."""
from __future__ import annotations

import pytest

from uav_insar_planner.track.cross_track import FRESH_S, LIMIT_M, TRUSTED_M, CrossTrack

TARGET = (-27.0, 10.0, 47.0)


def test_the_error_is_added_g_times_across_track_and_in_height_never_along_track():
    ct = CrossTrack(gain=1.0)
    s = ct.setpoint(TARGET, (-27.2, 12.0, 47.1), 0.05, now=1.0)
    assert s == pytest.approx((-26.8, 10.0, 46.9))  # first call: no integral yet
    s = ct.setpoint(TARGET, (-27.2, 12.0, 47.1), 0.05, now=1.1)
    assert s[0] > -26.8 and s[2] < 46.9 and s[1] == 10.0  # the integral grows with the error


@pytest.mark.parametrize("age", [FRESH_S + 0.01, -0.5])
def test_a_late_estimate_adds_nothing_but_keeps_the_integral(age):
    ct = CrossTrack(gain=1.0)
    ct.setpoint(TARGET, (-27.3, 10.0, 47.0), 0.0, now=0.0)
    ct.setpoint(TARGET, (-27.3, 10.0, 47.0), 0.0, now=0.4)
    learnt = ct.integral
    assert learnt != (0.0, 0.0)
    s = ct.setpoint(TARGET, (-29.0, 10.0, 47.0), age, now=0.5)
    assert s == pytest.approx((TARGET[0] + learnt[0], TARGET[1], TARGET[2] + learnt[1]))
    assert ct.integral == learnt


@pytest.mark.parametrize("estimate, age", [
    (None, 0.0), ((-27.0 + TRUSTED_M + 0.1, 10.0, 47.0), 0.0)])
def test_off_for_a_missing_or_untrusted_estimate_and_the_integral_forgotten(estimate, age):
    ct = CrossTrack(gain=1.0)
    ct.setpoint(TARGET, (-27.3, 10.0, 47.0), 0.0, now=0.0)
    ct.setpoint(TARGET, (-27.3, 10.0, 47.0), 0.0, now=0.4)
    assert ct.integral != (0.0, 0.0)
    assert ct.setpoint(TARGET, estimate, age, now=0.5) == TARGET
    assert ct.integral == (0.0, 0.0)


def test_gain_zero_is_the_target_as_planned():
    assert CrossTrack(gain=0.0).setpoint(TARGET, (-28.0, 10.0, 46.0), 0.0, 1.0) == TARGET


def test_the_correction_never_exceeds_its_limit():
    ct = CrossTrack(gain=1.0)
    for i in range(200):  # a vehicle that never moves: the integral saturates
        s = ct.setpoint(TARGET, (-28.5, 10.0, 47.0), 0.0, now=0.1 * i)
        assert abs(s[0] - TARGET[0]) <= LIMIT_M + 1e-12


def _fly(gain: float, seconds: float = 60.0, dt: float = 0.02) -> float:
    """The largest across-track error after 10 s of a soft loop (a position P of 0.95 /s and
    a velocity P of 1.8 /s, as PX4's defaults) pushed by a slow lateral acceleration (a
    0.15 m/s^2 sine of 12 s period), with the setpoint corrected every 0.1 s on a 0.1 s old
    estimate."""
    import math
    x = v = 0.0
    setpoint, worst, late = 0.0, 0.0, []
    ct = CrossTrack(gain)
    for i in range(int(seconds / dt)):
        t = i * dt
        if i % 5 == 0:
            late.append(x)
            seen = late[-2] if len(late) > 1 else x
            setpoint = ct.setpoint((0.0, 0.0, 0.0), (seen, 0.0, 0.0), 0.1, t)[0]
        acc = 1.8 * (0.95 * (setpoint - x) - v) + 0.15 * math.sin(2 * math.pi * t / 12.0)
        v += acc * dt
        x += v * dt
        if t > 10.0:
            worst = max(worst, abs(x))
    return worst


def test_closed_around_a_soft_loop_it_holds_a_slow_push_to_a_fraction():
    alone, corrected = _fly(0.0), _fly(1.0)
    assert corrected < 0.5 * alone, (alone, corrected)
