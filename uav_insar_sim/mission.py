"""Position source for a UAV the agent flies itself, on the mission clock, without ROS.

Flight: `transit` is a 3-D flight from home to the run-up point (x_k, -v^2/(2 a), z_k),
arriving at rest; `track` is the along-track run-up, then slot n starts exactly when the UAV
reaches y = n v_y delta_t (track time `kinematics.slot_start`), with across-track (x, z) held
on the plan's target; `done` brakes to a hover straight ahead once all slots are flown;
`hold` (the plan took this UAV out in mid-flight, slots.SlotSchedule.set_plan) brakes the
same way at once. The slots themselves are `slots.SlotSchedule`'s.

The position handed to the schedule at a slot's start is the flown position plus, optionally,
a Gaussian disturbance of `noise_std` metres per axis (wind, GNSS error) drawn from a seeded
generator, so the slot rates are reproducible for a given seed.

Wind (`wind.Wind`, off by default): the point-mass velocity is then air-relative and the
ground track moves by (v + w) h per step, while the position controller flies to the same
targets as without wind and fights the drift it sees: transit ends within
`Wind.settled_offset_m` + ARRIVAL_M of the run-up point, the track follows the moving
along-track target (x_k, y(tau), z_k) with its velocity (0, v_y(tau), 0) (slots still start on
the track clock, wherever the wind has put the UAV), and `done` holds a point straight ahead.
Without wind every step is today's, exactly.
"""
from __future__ import annotations

import numpy as np

from uav_insar_planner.params import Params
from uav_insar_planner.plan import Vec3
from uav_insar_sim.fading import LinkFading
from uav_insar_sim.offload import ClosedLoopOffload
from uav_insar_sim.physics.kinematics import (
    PointMass,
    runup_and_cruise,
    runup_distance,
    slot_start,
    step_toward,
)
from uav_insar_sim.slots import Phase, SlotSample, SlotSchedule
from uav_insar_sim.wind import Wind

# Integration step on the mission clock; slot starts are hit exactly regardless.
MAX_STEP_S = 0.05
# Homes on the ground, 5 m apart, 30 m before the track start, so agents never share a point.
HOME_Y_M = -30.0
HOME_SPACING_M = 5.0
# Under wind: the run-up point counts as reached this close, beyond the wind's settled offset.
ARRIVAL_M = 0.5


def home_position(uav_id: int) -> np.ndarray:
    """Where agent `uav_id` starts (x, y, z) in the track frame."""
    return np.array([uav_id * HOME_SPACING_M, HOME_Y_M, 0.0])


class Mission(SlotSchedule):
    """The flight of agent `uav_id` under `params` (SI), advanced with `advance(t)`.

    `wind`, `fading`, `controller`: see the module doc and slots.SlotSchedule (None: off).
    ValueError when `max_speed` is below the track speed."""

    def __init__(self, uav_id: int, params: Params, max_speed: float, max_accel: float,
                 noise_std: float = 0.0, noise_seed: int = 0, wind: Wind | None = None,
                 fading: LinkFading | None = None,
                 controller: ClosedLoopOffload | None = None):
        if max_speed < params.speed:
            raise ValueError(f"max_speed_mps: value {max_speed!r} is not allowed; expected at "
                             f"least speed_mps ({params.speed!r})")
        super().__init__(uav_id, params, fading, controller)
        self.wind = None if wind is None or wind.off else wind
        self._hold: np.ndarray | None = None
        self.max_speed = max_speed
        self.max_accel = max_accel
        self.noise_std = noise_std
        # Separate streams: slot samples stay reproducible however often poses are published.
        self._slot_rng = np.random.default_rng([noise_seed, uav_id, 0])
        self._pose_rng = np.random.default_rng([noise_seed, uav_id, 1])
        self.t = 0.0
        self.state = PointMass(home_position(uav_id), np.zeros(3))
        self._track_t0 = 0.0

    def actual_position(self) -> Vec3:
        """Current position as published on /uavK/pose (flown position plus disturbance)."""
        return self._disturbed(self._pose_rng)

    def advance(self, t: float) -> list[SlotSample]:
        """Fly until mission time `t`; return the slots that started on the way, in order."""
        started: list[SlotSample] = []
        while self.t < t:
            h = min(MAX_STEP_S, t - self.t)
            event = self._next_slot_time()
            if event is not None and event > self.t:
                h = min(h, event - self.t)
            self._step(h)
            self.t += h
            if event is not None and abs(self.t - event) < 1e-9:
                self.t = event
                started.append(self.start_slot(self._disturbed(self._slot_rng)))
        return started

    def _next_slot_time(self) -> float | None:
        if self.phase is not Phase.TRACK or self.all_flown:
            return None
        p = self.params
        return self._track_t0 + slot_start(len(self.samples), p.speed, self.max_accel,
                                           p.slot_duration_s)

    def _step(self, h: float) -> None:
        if self.wind is not None:
            self._step_in_wind(h)
            return
        p = self.params
        if self.phase is Phase.TRANSIT:
            x, z = self.target_xz
            runup = np.array([x, -runup_distance(p.speed, self.max_accel), z])
            self.state = step_toward(self.state, runup, h, self.max_speed, self.max_accel)
            if np.array_equal(self.state.position, runup) and not self.state.velocity.any():
                self.phase, self._track_t0 = Phase.TRACK, self.t + h
        elif self.phase is Phase.TRACK:
            tau = self.t + h - self._track_t0
            y, vy = runup_and_cruise(tau, p.speed, self.max_accel)
            xz = PointMass(self.state.position[[0, 2]], self.state.velocity[[0, 2]])
            xz = step_toward(xz, np.array(self.target_xz), h, self.max_speed, self.max_accel)
            self.state = PointMass(np.array([xz.position[0], y, xz.position[1]]),
                                   np.array([xz.velocity[0], vy, xz.velocity[1]]))
            end = slot_start(self.num_slots, p.speed, self.max_accel, p.slot_duration_s)
            if self.all_flown and tau >= end - 1e-9:
                self.phase = Phase.DONE
        elif self.phase.over and self.state.velocity.any():
            # A velocity command of zero: brake at max_accel to a hover straight ahead.
            self.state = step_toward(self.state, None, h, self.max_speed, self.max_accel)

    def _step_in_wind(self, h: float) -> None:
        p, wind = self.params, self.wind.step(h)
        target, v_t = None, None
        if self.phase is Phase.TRANSIT:
            x, z = self.target_xz
            target = np.array([x, -runup_distance(p.speed, self.max_accel), z])
        elif self.phase is Phase.TRACK:
            y, vy = runup_and_cruise(self.t + h - self._track_t0, p.speed, self.max_accel)
            target, v_t = np.array([self.target_xz[0], y, self.target_xz[1]]), (0.0, vy, 0.0)
        elif self.phase.over:
            if self._hold is None:
                self._hold = self.state.position + np.array(
                    [0.0, runup_distance(max(self.state.velocity[1], 0.0), self.max_accel),
                     0.0])
            target = self._hold
        if target is not None or self.state.velocity.any():
            air = step_toward(self.state, target, h, self.max_speed, self.max_accel, v_t)
            self.state = PointMass(self.state.position + (air.velocity + wind) * h,
                                   air.velocity)
        if self.phase is Phase.TRANSIT:
            gap = float(np.linalg.norm(self.state.position - target))
            if gap <= self.wind.settled_offset_m(self.max_accel) + ARRIVAL_M:
                self.phase, self._track_t0 = Phase.TRACK, self.t + h
        elif self.phase is Phase.TRACK and self.all_flown:
            end = slot_start(self.num_slots, p.speed, self.max_accel, p.slot_duration_s)
            if self.t + h - self._track_t0 >= end - 1e-9:
                self.phase = Phase.DONE

    def _disturbed(self, rng: np.random.Generator) -> Vec3:
        pos = self.state.position
        if self.noise_std > 0.0:
            pos = pos + rng.normal(0.0, self.noise_std, 3)
        return (float(pos[0]), float(pos[1]), float(pos[2]))
