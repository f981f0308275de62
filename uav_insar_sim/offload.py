"""Closed-loop offloading: each slot, the least power that meets R_min, within C9 and C11.

Open loop (the default) applies the planner's P_com[k][n] as it is. Closed loop
(`ClosedLoopOffload`) re-chooses the power at the start of every slot n from what the agent
measures: its position q_n (as measured) and the rates achieved in the slots before.

Model the agent believes: R = B_c log2(1 + P g beta_c / d^2) with an unknown channel gain g.
After slot m it knows the power P_m it applied, the rate R_m it achieved and where it was,
so it measures the gain error in dB

    e_m = 10 log10( (2^(R_m / B_c) - 1) d_m^2 / (P_m beta_c) )      (0 dB: the paper's link)

and tracks it with exponential smoothing: innovation i_m = e_m - ehat, ehat <- ehat + ALPHA i_m,
s^2 <- (1 - BETA) s^2 + BETA i_m^2 (both start at 0). The margin is M = Z s dB (a fading
channel's spread of the gain around its tracked mean).

Slot n then needs, at the measured position q_n (d_n = |q_n - g|), for a rate R

    P_n(R) = (2^(R / B_c) - 1) d_n^2 / (beta_c 10^((ehat - M) / 10))

and aims at P*_n = P_n((1 + mu) R_min), the plan's rate margin mu (`rate_margin`) on top.

and the later slots m > n need about w_m = P_plan[m] 10^((M - ehat) / 10) each (the plan's
power corrected the same way). C11 spreads the energy left E_left = E_max - E_used over the
slots left in proportion to their need, and C9 caps the peak:

    P_n = clamp(P*_n, 0, min(P_max, E_left P*_n / ((P*_n + sum_{m>n} w_m) delta_t)))

and when that share would leave even R_min unmet, the energy headroom pays for it: P_n is
raised to P_n(R_min), within P_max and the energy left (E_left / delta_t). So the energy used
never exceeds E_max; when the budget covers every need the cap does not bind and each slot
gets exactly the least power that meets (1 + mu) R_min at the tracked gain, and R_min is met in
every slot that P_max and E_max allow where the UAV actually is. With no fading and no
position error, e_m = 0, M = 0 and P_n is the plan's power (the plan sizes P_com[k][n] to meet
(1 + mu) R_min exactly at the planned position).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.schemes import planned_rate_bps

ALPHA = 0.5  # smoothing of the gain error estimate ehat
BETA = 0.2  # smoothing of its squared innovation s^2
Z = 1.28  # margin in innovation stds (about 90 % of slots one-sided, for a Gaussian spread)


class ClosedLoopOffload:
    """The closed-loop law of the module doc for UAV `uav_id` under `params` (SI)."""

    def __init__(self, uav_id: int, params: Params):
        self.p = params
        self.rate_min = float(params.rate_min_bps[uav_id])
        # the closed loop chooses the power, so the plan's margin applies whatever the scheme
        self.rate_aim = planned_rate_bps(params, uav_id, "proposed")
        self.error_db = 0.0
        self.var_db2 = 0.0

    @property
    def margin_db(self) -> float:
        return Z * math.sqrt(self.var_db2)

    def _d2(self, position: Sequence[float]) -> float:
        x, y, z = position
        return float(model.distance_to_station(x, y, z, tuple(self.p.ground_station))) ** 2

    def power(self, n: int, position: Sequence[float], planned: Sequence[float],
              energy_used_j: float) -> float:
        """P_n [W] for slot n at the measured `position`, given the plan's powers `planned`
        (P_com[k][:]) and the energy used so far."""
        p = self.p
        correction = 10.0 ** ((self.margin_db - self.error_db) / 10.0)
        per_snr = self._d2(position) / p.beta_c * correction  # watts per unit of SNR

        def needs(rate: float) -> float:
            return math.expm1(rate / p.comm_bandwidth_hz * math.log(2.0)) * per_snr

        need = needs(self.rate_aim)
        later = sum(max(0.0, w) for w in planned[n + 1:]) * correction
        left = max(0.0, p.e_max_j - energy_used_j)
        share = need / (need + later) if need + later > 0.0 else 1.0 / max(1, len(planned) - n)
        hard = min(p.p_max_w, left / p.slot_duration_s)
        fair = min(need, hard, left * share / p.slot_duration_s)
        return max(0.0, fair, min(needs(self.rate_min), hard))

    def observe(self, position: Sequence[float], power_w: float, rate_bps: float) -> None:
        """Learn from a flown slot: where it was, the power applied, the rate achieved."""
        if power_w <= 0.0 or rate_bps <= 0.0:
            return  # nothing measured
        p = self.p
        gain = (2.0 ** (rate_bps / p.comm_bandwidth_hz) - 1.0) * self._d2(position) / (
            power_w * p.beta_c)
        innovation = 10.0 * math.log10(gain) - self.error_db
        self.error_db += ALPHA * innovation
        self.var_db2 = (1.0 - BETA) * self.var_db2 + BETA * innovation * innovation
