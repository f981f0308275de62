"""A seeded wind disturbance on the self-flown agent's kinematics: steady wind plus gusts.

Wind velocity (track frame, m/s) at mission time t:

    w(t) = w_steady + u(t)

with u a first-order Gauss-Markov process per axis (physics/gauss_markov.py; the Dryden turbulence
spectrum to first order), stationary std sigma_g and time constant tau_g. Draws come from a
generator seeded by (seed, uav_id, 2), so a mission under wind is reproducible for a seed.

How it acts (mission.Mission): the point-mass velocity is the UAV's air-relative velocity,
bounded by max_speed and max_accel as before; the ground track moves by (v + w) h per step.
The position controller does not know the wind; it sees the position error the wind causes
and fights it, so under a steady wind w the UAV settles downwind of its target by roughly
|w|^2 / (2 a_max) (the sqrt(2 a d) approach law of kinematics.step_toward run backwards).
Off (w_steady = 0, sigma_g = 0) the mission is today's, exactly.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from uav_insar_sim.physics.gauss_markov import GaussMarkov


class Wind:
    """Steady wind plus Gauss-Markov gusts (module doc); `step(h)` advances and returns w."""

    def __init__(self, steady_mps: Sequence[float] = (0.0, 0.0, 0.0), gust_std_mps: float = 0.0,
                 gust_tau_s: float = 2.0, seed: int = 0, uav_id: int = 0):
        if gust_std_mps < 0.0 or gust_tau_s <= 0.0:
            raise ValueError("gust_std_mps must be >= 0 and gust_tau_s > 0")
        self.steady = np.asarray(steady_mps, dtype=float).reshape(3)
        self.gust_std = float(gust_std_mps)
        self.tau = float(gust_tau_s)
        self._gusts = GaussMarkov(self.gust_std, self.tau,
                                  np.random.default_rng([seed, uav_id, 2]))

    @property
    def off(self) -> bool:
        return not self.steady.any() and self.gust_std == 0.0

    @property
    def velocity(self) -> np.ndarray:
        """The wind now [m/s]."""
        return self.steady + self._gusts.value

    def step(self, h: float) -> np.ndarray:
        """Advance the gusts by `h` seconds; return the wind over that step [m/s]."""
        self._gusts.step(h)
        return self.velocity

    def settled_offset_m(self, max_accel: float) -> float:
        """Rough steady-state distance from a held target under the wind's worst speed."""
        worst = float(np.linalg.norm(self.steady)) + 3.0 * self.gust_std
        return worst * worst / (2.0 * max_accel)
