"""The radio link from a UAV to the ground station: the paper's FDMA free-space rate (eq. 17).

The planner sizes P_com[k][n] for the planned position q_k[n] = (x_k, y[n], z_k); the agent
calls `achieved_rate` with where it actually is, so any position error shows up as a rate
margin (positive closer to the station, negative farther away). `gain` is the simulated
link's channel power gain (fading.LinkFading; 1, the default, is the paper's link exactly).
"""
from __future__ import annotations

from collections.abc import Sequence

from uav_insar_planner import model


def achieved_rate(position: Sequence[float], p_com_w: float,
                  station: Sequence[float], bandwidth_hz: float, beta_c: float,
                  gain: float = 1.0) -> float:
    """R = B_c log2(1 + P_com g beta_c / d^2) in bit/s, d = |position - station| (3-D,
    metres), g = `gain`."""
    x, y, z = position
    d = model.distance_to_station(x, y, z, tuple(station))
    power = p_com_w if gain == 1.0 else p_com_w * gain
    return float(model.fdma_rate(power, d, bandwidth_hz, beta_c))
