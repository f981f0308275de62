"""The error of the simulated vehicle's position estimate, as an EKF's under GNSS noise.

A real copter's reported position wanders about where it is by decimetres with a correlation
time of seconds (GNSS multipath and atmosphere, smoothed by the EKF): not white noise at the
telemetry rate. Here it is a Gauss-Markov process per NED axis (physics/gauss_markov.py) of std
`std_m` and time constant `tau_s`, advanced with every physics tick; its generator is seeded
by (seed, sysid, 4), so each vehicle of a seeded run wanders its own reproducible way.

What it touches (telemetry.py): the positions reported in LOCAL_POSITION_NED,
GLOBAL_POSITION_INT and GPS_RAW_INT. The flight holds its setpoint with the true position
(vehicle.position_ned), so a hovering vehicle's reported position jitters about its setpoint
by the error, as a real one's does seen from the ground station. Velocities (GNSS Doppler, a
few cm/s on a real receiver), home and origin are reported without it.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from uav_insar_sim.physics.gauss_markov import GaussMarkov

MAX_STD_M = 100.0
DEFAULT_TAU_S = 2.0
MAX_TAU_S = 3600.0


def check(std_m: float, tau_s: float, seed: int) -> None:
    """ValueError (one line naming the option) when one of the three is not allowed."""
    if not 0.0 <= std_m <= MAX_STD_M:  # (False for NaN)
        raise ValueError(f"position_noise_std: value {std_m!r:.24} is not allowed; expected "
                         f"0 <= m <= {MAX_STD_M:g}")
    if not 0.0 < tau_s <= MAX_TAU_S:
        raise ValueError(f"position_noise_tau: value {tau_s!r:.24} is not allowed; expected "
                         f"0 < s <= {MAX_TAU_S:g}")
    if not 0 <= seed < 2**31:
        raise ValueError(f"noise_seed: value {seed!r:.24} is not allowed; expected "
                         "0 <= seed < 2^31")


class EstimateError:
    """The error now (`ned`, metres) and `step(h)` to advance it; std 0 is no error at all."""

    def __init__(self, std_m: float = 0.0, tau_s: float = DEFAULT_TAU_S, seed: int = 0,
                 sysid: int = 1):
        check(std_m, tau_s, seed)
        self._process = GaussMarkov(std_m, tau_s, np.random.default_rng([seed, sysid, 4]))

    @property
    def ned(self) -> tuple[float, float, float]:
        n, e, d = (float(c) for c in self._process.value)
        return n, e, d

    def step(self, h: float) -> None:
        if math.isfinite(h):
            self._process.step(h)

    def reported(self, position: Sequence[float]) -> tuple[float, float, float]:
        """`position` (N, E, D) as the estimate reports it."""
        n, e, d = self.ned
        return position[0] + n, position[1] + e, position[2] + d
