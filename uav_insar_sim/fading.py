"""A simulated link that can differ from the plan: seeded shadowing and Rician fading.

The planner sizes P_com[k][n] with the paper's free-space model, R = B_c log2(1 + P beta_c /
d^2). The simulator may multiply the received power by a channel power gain g_n (linear):

    R_n = B_c log2(1 + P_n g_n beta_c / d_n^2),   g_n = 10^(S_n / 10) |h_n|^2

- Large-scale fading: log-normal shadowing S_n [dB], zero mean, std sigma_S, correlated along
  the track with Gudmundson's exponential autocorrelation E[S(s) S(s + D)] = sigma_S^2
  exp(-|D| / d_corr), sampled as the exact AR(1) over the distance D_n flown between two
  consecutive slot starts:

      S_0 = sigma_S w_0,   S_n = rho_n S_{n-1} + sigma_S sqrt(1 - rho_n^2) w_n,
      rho_n = exp(-D_n / d_corr),   w_n ~ N(0, 1) i.i.d.

  (median gain 1, i.e. 0 dB; the mean linear gain is exp((sigma_S ln10 / 10)^2 / 2)).
- Small-scale fading: Rician with K-factor K (linear, from dB), independent per slot (a slot
  spans metres, many wavelengths):

      h_n = sqrt(K / (K + 1)) + sqrt(1 / (K + 1)) c_n,   c_n ~ CN(0, 1),   E|h_n|^2 = 1.

  K = None (off) means |h_n|^2 = 1.

Both off (sigma_S = 0, K None) gives g_n = 1.0 exactly with no random draw, so the rates are
the paper's bit for bit. Draws come from a generator seeded by (seed, uav_id, 3): one stream per
UAV, reproducible for a seed, independent of the position noise's streams.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from uav_insar_planner.param_specs.science import db_to_linear


class LinkFading:
    """Per-slot channel power gain g_n of one UAV's link (module doc); call `gain` once per
    slot, in slot order, with the position at the slot's start."""

    def __init__(self, shadowing_std_db: float = 0.0, corr_m: float = 20.0,
                 rician_k_db: float | None = None, seed: int = 0, uav_id: int = 0):
        if shadowing_std_db < 0.0 or corr_m <= 0.0:
            raise ValueError("shadowing_std_db must be >= 0 and shadowing_corr_m > 0")
        self.std_db = float(shadowing_std_db)
        self.corr_m = float(corr_m)
        self.k = None if rician_k_db is None else db_to_linear(rician_k_db)
        self._rng = np.random.default_rng([seed, uav_id, 3])
        self._s_db: float | None = None
        self._last: np.ndarray | None = None

    @property
    def off(self) -> bool:
        return self.std_db == 0.0 and self.k is None

    def gain(self, position: Sequence[float]) -> float:
        """g_n at `position` (x, y, z) [m]: the next draw of the shadowing and fading."""
        if self.off:
            return 1.0
        here = np.asarray(position, dtype=float)
        g = 1.0
        if self.std_db > 0.0:
            w = float(self._rng.standard_normal())
            if self._s_db is None:
                self._s_db = self.std_db * w
            else:
                rho = math.exp(-float(np.linalg.norm(here - self._last)) / self.corr_m)
                self._s_db = rho * self._s_db + self.std_db * math.sqrt(1.0 - rho * rho) * w
            g *= db_to_linear(self._s_db)
        self._last = here
        if self.k is not None:
            re, im = self._rng.standard_normal(2) * math.sqrt(0.5)
            scatter = math.sqrt(1.0 / (self.k + 1.0))
            h_re = math.sqrt(self.k / (self.k + 1.0)) + scatter * re
            g *= h_re * h_re + (scatter * im) ** 2
        return g
