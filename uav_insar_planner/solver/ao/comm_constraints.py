"""C9-C11 for one UAV inside a CVXPY sub-problem, with P_com,k a decision variable.

C10 is written in the paper's convex form P_com,k[n] beta_c >= (2^(R_min,k/B_c) - 1) d_k,n^2,
with d_k,n^2 = ||q_k - g_xz||^2 + (y[n] - g_y)^2 (section II-B); the x-z part enters through one
epigraph variable t >= ||q_k - g_xz||^2 so the N slot constraints stay linear. Benchmark 3 fixes
P_com,k[n] = E_max / (N delta_t) instead of making it a variable; C10 is then the disk
||q_k - g_xz||^2 <= beta_c P / (2^(R/B) - 1) - max_n (y[n] - g_y)^2 (C9, C11 hold by choice
of P when P <= P_max, which the start grid checks).
"""
from __future__ import annotations

import math

import cvxpy as cp
import numpy as np

from uav_insar_planner.params import Params
from uav_insar_planner.schemes import planned_rate_bps, static_power_w


def comm_constraints(p: Params, k: int, q: cp.Expression, scheme: str
                     ) -> tuple[cp.Expression, list[cp.Constraint]]:
    """(P_com,k as an expression of length N, constraints C9-C11 for UAV k at position q)."""
    n = p.num_slots
    if scheme == "static-power":
        power: cp.Expression = cp.Constant(np.full(n, static_power_w(p)))
        cons: list[cp.Constraint] = []
    else:
        power = cp.Variable(n, name=f"P_com_{k}")
        cons = [power >= 0, power <= p.p_max_w,                                      # C9
                cp.sum(power) * p.slot_duration_s <= p.energy_budget_j(k)]            # C11
    spectral = math.expm1(planned_rate_bps(p, k, scheme) / p.comm_bandwidth_hz * math.log(2.0))
    gxz = np.array([p.ground_station[0], p.ground_station[2]])
    dy2 = (p.y_track - p.ground_station[1]) ** 2
    if spectral > 0.0 and scheme == "static-power":
        # fixed power: C10 in every slot is one disk around the station (worst slot binds);
        # one cone instead of N parallel cuts keeps the interior-point solve well conditioned
        rho2 = p.beta_c * static_power_w(p) / spectral - float(dy2.max())
        # (rho2 < 0 never reaches here: the start grid finds no start and C10 is reported)
        cons.append(cp.norm(q - gxz) <= math.sqrt(max(rho2, 0.0)))
    elif spectral > 0.0:
        t = cp.Variable(name=f"d2_{k}")
        cons += [cp.sum_squares(q - gxz) <= t,
                 p.beta_c * power >= spectral * (t + dy2)]                           # C10
    return power, cons
