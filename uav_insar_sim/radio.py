"""The radio link from a UAV to the ground station: the paper's FDMA free-space rate (eq. 17).

The planner sizes P_com[k][n] for the planned position q_k[n] = (x_k, y[n], z_k); the agent
calls `achieved_rate` with where it actually is, so any position error shows up as a rate
margin (positive closer to the station, negative farther away).
"""
from __future__ import annotations

from collections.abc import Sequence

from uav_insar_planner import model


def achieved_rate(position: Sequence[float], p_com_w: float,
                  station: Sequence[float], bandwidth_hz: float, beta_c: float) -> float:
    """R = B_c log2(1 + P_com beta_c / d^2) in bit/s, d = |position - station| (3-D, metres)."""
    x, y, z = position
    d = model.distance_to_station(x, y, z, tuple(station))
    return float(model.fdma_rate(p_com_w, d, bandwidth_hz, beta_c))
