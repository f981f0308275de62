"""Pure checks of the agent's point-mass kinematics (no ROS)."""
import numpy as np
import pytest

from uav_insar_sim.physics.kinematics import (
    PointMass,
    runup_and_cruise,
    runup_distance,
    slot_start,
    step_toward,
)


def fly(state, target, dt, vmax, amax, steps, target_velocity=None):
    track = [state]
    for _ in range(steps):
        state = step_toward(state, target, dt, vmax, amax, target_velocity)
        track.append(state)
    return track


def test_point_to_point_respects_bounds_and_lands_exactly_at_rest():
    dt, vmax, amax = 0.05, 10.0, 3.0
    target = np.array([-40.0, -3.1, 60.0])
    track = fly(PointMass(np.zeros(3), np.zeros(3)), target, dt, vmax, amax, 2000)
    speeds = [np.linalg.norm(s.velocity) for s in track]
    accels = [np.linalg.norm(b.velocity - a.velocity) / dt
              for a, b in zip(track, track[1:], strict=False)]
    assert max(speeds) <= vmax + 1e-9
    assert max(accels) <= amax + 1e-9
    assert max(speeds) > 0.9 * vmax  # a 72 m hop does reach cruise speed
    assert np.array_equal(track[-1].position, target)
    assert not track[-1].velocity.any()


def test_arrival_time_is_close_to_the_bang_bang_minimum():
    dt, vmax, amax, dist = 0.05, 10.0, 3.0, 72.0
    track = fly(PointMass(np.zeros(1), np.zeros(1)), np.array([dist]), dt, vmax, amax, 2000)
    steps = next(i for i, s in enumerate(track) if s.position[0] == dist)
    t_min = dist / vmax + vmax / amax  # accelerate, cruise, brake
    assert t_min <= steps * dt <= t_min + 1.0


def test_follows_a_moving_target_with_its_velocity():
    dt, v = 0.05, np.array([0.0, 4.3])
    state = PointMass(np.array([1.0, 0.0]), np.zeros(2))
    for i in range(400):
        target = np.array([0.0, 4.3 * i * dt])
        state = step_toward(state, target, dt, 10.0, 3.0, v)
    assert np.allclose(state.velocity, v, atol=1e-9)
    assert np.allclose(state.position, [0.0, 4.3 * 400 * dt], atol=1e-9)


@pytest.mark.parametrize("speed,accel", [(4.3, 3.0), (1.0, 0.5)])
def test_run_up_reaches_speed_at_y0_and_slots_start_on_the_model_grid(speed, accel):
    y, vy = runup_and_cruise(0.0, speed, accel)
    assert (y, vy) == (-runup_distance(speed, accel), 0.0)
    assert runup_and_cruise(speed / accel, speed, accel) == pytest.approx((0.0, speed))
    for n in range(5):
        y, vy = runup_and_cruise(slot_start(n, speed, accel, 1.5), speed, accel)
        assert y == pytest.approx(n * speed * 1.5)
        assert vy == speed
