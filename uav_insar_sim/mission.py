"""One simulated UAV's mission on the mission clock, without ROS (the agent node drives it).

Phases: `wait` (no plan yet) -> `transit` (3-D flight from home to the run-up point
(x_k, -v^2/(2 a), z_k), arriving at rest) -> `track` (along-track run-up, then slot n starts at
y = n v_y delta_t; across-track (x, z) is held on the plan's target) -> `done` (all slots flown,
brakes to a hover). `idle` means the plan does not fly this UAV (single-baseline's U2).

In each slot the agent transmits its scheduled P_com[k][n] and the link rate is computed at
the slot's start from the *actual* position: the flown position plus, optionally, a Gaussian
disturbance of `noise_std` metres per axis (wind, GNSS error) drawn from a seeded generator,
so the slot rates are reproducible for a given seed.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from uav_insar_planner.params import Params
from uav_insar_sim.kinematics import PointMass, along_track, runup_distance, slot_start, step_toward
from uav_insar_sim.link import achieved_rate

# Integration step on the mission clock; slot starts are hit exactly regardless.
MAX_STEP_S = 0.05
# Homes on the ground, 5 m apart, 30 m before the track start, so agents never share a point.
HOME_Y_M = -30.0
HOME_SPACING_M = 5.0


def home_position(uav_id: int) -> np.ndarray:
    """Where agent `uav_id` starts (x, y, z) in the track frame."""
    return np.array([uav_id * HOME_SPACING_M, HOME_Y_M, 0.0])


@dataclass
class SlotSample:
    """One flown slot: where the UAV actually was at its start, the power applied, the rate."""

    slot: int
    position: tuple[float, float, float]
    power_w: float
    rate_bps: float
    rate_min_bps: float

    @property
    def margin_bps(self) -> float:
        return self.rate_bps - self.rate_min_bps


class Mission:
    """The flight of agent `uav_id` under `params` (SI), advanced with `advance(t)`."""

    def __init__(self, uav_id: int, params: Params, max_speed: float, max_accel: float,
                 noise_std: float = 0.0, noise_seed: int = 0):
        if max_speed < params.speed:
            raise ValueError(f"max_speed_mps: value {max_speed!r} is not allowed; expected at "
                             f"least speed_mps ({params.speed!r})")
        self.uav_id = uav_id
        self.params = params
        self.max_speed = max_speed
        self.max_accel = max_accel
        self.noise_std = noise_std
        # Separate streams: slot samples stay reproducible however often poses are published.
        self._slot_rng = np.random.default_rng([noise_seed, uav_id, 0])
        self._pose_rng = np.random.default_rng([noise_seed, uav_id, 1])
        self.phase = "wait"
        self.t = 0.0
        self.state = PointMass(home_position(uav_id), np.zeros(3))
        self.target_xz: tuple[float, float] | None = None
        self.powers: list[float] = []
        self.samples: list[SlotSample] = []
        self._track_t0 = 0.0

    @property
    def num_slots(self) -> int:
        return len(self.powers)

    def set_plan(self, target_xz: tuple[float, float], powers: Sequence[float]) -> None:
        """Adopt a (new) plan: target (x_k, z_k) and schedule P_com[k][:]; the clock runs on.

        A replan during the track re-targets across-track while the slots continue; once the
        mission is done, later plans are ignored.
        """
        if self.phase == "done":
            return
        if not all(math.isfinite(v) for v in target_xz):
            self.phase = "idle"
            return
        self.target_xz = (float(target_xz[0]), float(target_xz[1]))
        self.powers = [float(p) for p in powers]
        if self.phase in ("wait", "idle"):
            self.phase = "transit"

    def actual_position(self) -> tuple[float, float, float]:
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
                started.append(self._sample_slot())
        return started

    def _next_slot_time(self) -> float | None:
        if self.phase != "track" or len(self.samples) >= self.num_slots:
            return None
        p = self.params
        return self._track_t0 + slot_start(len(self.samples), p.speed, self.max_accel,
                                           p.slot_duration_s)

    def _step(self, h: float) -> None:
        p = self.params
        if self.phase == "transit":
            x, z = self.target_xz
            runup = np.array([x, -runup_distance(p.speed, self.max_accel), z])
            self.state = step_toward(self.state, runup, h, self.max_speed, self.max_accel)
            if np.array_equal(self.state.position, runup) and not self.state.velocity.any():
                self.phase, self._track_t0 = "track", self.t + h
        elif self.phase == "track":
            tau = self.t + h - self._track_t0
            y, vy = along_track(tau, p.speed, self.max_accel)
            xz = PointMass(self.state.position[[0, 2]], self.state.velocity[[0, 2]])
            xz = step_toward(xz, np.array(self.target_xz), h, self.max_speed, self.max_accel)
            self.state = PointMass(np.array([xz.position[0], y, xz.position[1]]),
                                   np.array([xz.velocity[0], vy, xz.velocity[1]]))
            end = slot_start(self.num_slots, p.speed, self.max_accel, p.slot_duration_s)
            if len(self.samples) >= self.num_slots and tau >= end - 1e-9:
                self.phase = "done"
        elif self.phase == "done" and self.state.velocity.any():
            # Brake at max_accel to a hover straight ahead.
            v = self.state.velocity
            speed = float(np.linalg.norm(v))
            v_new = v * max(0.0, 1.0 - self.max_accel * h / speed)
            self.state = PointMass(self.state.position + 0.5 * (v + v_new) * h, v_new)

    def _disturbed(self, rng: np.random.Generator) -> tuple[float, float, float]:
        pos = self.state.position
        if self.noise_std > 0.0:
            pos = pos + rng.normal(0.0, self.noise_std, 3)
        return (float(pos[0]), float(pos[1]), float(pos[2]))

    def _sample_slot(self) -> SlotSample:
        p = self.params
        n = len(self.samples)
        position = self._disturbed(self._slot_rng)
        rate = achieved_rate(position, self.powers[n], p.ground_station, p.comm_bandwidth_hz,
                             p.beta_c)
        sample = SlotSample(n, position, self.powers[n], rate, p.rate_min_bps[self.uav_id])
        self.samples.append(sample)
        return sample
