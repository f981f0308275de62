"""A first-order Gauss-Markov process per axis: the one model of the simulator's slowly
wandering disturbances (wind.py's gusts, the MAVLink vehicle's position estimate error).

    dx = -x / tau dt + sigma sqrt(2 / tau) dW,

stationary std sigma per axis, time constant tau, sampled exactly over a step h:
x(t + h) = a x(t) + sigma sqrt(1 - a^2) w, a = exp(-h / tau), w ~ N(0, I); x(0) drawn from the
stationary N(0, sigma^2 I). Unlike white noise at the sampling rate, successive samples h << tau
apart differ by about sigma sqrt(2 h / tau): the process wanders, it does not flicker.
"""
from __future__ import annotations

import math

import numpy as np


class GaussMarkov:
    """The process above in `dim` axes, drawing from `rng`; sigma 0 stays at zero and draws
    nothing. `step(h)` advances it and returns the new value (`value`)."""

    def __init__(self, sigma: float, tau_s: float, rng: np.random.Generator, dim: int = 3):
        if not (sigma >= 0.0 and tau_s > 0.0):  # (False for NaN)
            raise ValueError(f"sigma {sigma!r:.24} must be >= 0 and tau_s {tau_s!r:.24} > 0")
        self.sigma, self.tau_s, self._rng = float(sigma), float(tau_s), rng
        self.value = rng.normal(0.0, self.sigma, dim) if self.sigma > 0.0 else np.zeros(dim)

    def step(self, h: float) -> np.ndarray:
        if self.sigma > 0.0 and h > 0.0:
            a = math.exp(-h / self.tau_s)
            self.value = a * self.value + self.sigma * math.sqrt(1.0 - a * a) * \
                self._rng.standard_normal(self.value.shape)
        return self.value
