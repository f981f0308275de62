"""Communication power: the cheapest schedule for a position, and the distance limits it implies.

For a fixed position the least power meeting C10 in slot n is
P_k[n] = c_k d_k,n^2 with c_k = (2^(R_k / B_c) - 1) / beta_c, R_k = (1 + mu) R_min,k the rate
a plan holds (`schemes.planned_rate_bps`, mu = rate_margin). With
d_k,n^2 = rho_k^2 + (y[n] - g_y)^2 (rho_k the x-z distance to the station), C9 and C11 hold
for that schedule iff rho_k^2 <= station_radius_sq(k); any other feasible schedule uses at least
as much power in every slot, so this disk is exact, not a relaxation. For the static-power scheme
P = E_max/(N delta_t) is fixed and C10 alone gives the disk. Both back ends, the start grid and
the formation plot take the disk from here.

Navigation error e = nav_error_m (solver/robust.py): a UAV anywhere within e of its planned
point in the x-z plane is at most rho_k + e from the station there, and exactly that far when it
moves straight away from it; so the schedule P_k[n] = c_k ((rho_k + e)^2 + (y[n] - g_y)^2)
keeps C10 at every such position, and no smaller one does. C9 and C11 depend on the schedule
alone, so they hold iff (rho_k + e)^2 lies in the disk above: the disk's radius shrinks by e,
exactly (none left when e exceeds it). e = 0 is the nominal plan, computed as before.
"""
from __future__ import annotations

import math

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.schemes import planned_rate_bps, static_power_w


def rate_cost(p: Params, k: int, scheme: str) -> float:
    """c_k = (2^(R_k/B_c) - 1) / beta_c, watts per square metre of distance."""
    return float(model.power_for_rate(planned_rate_bps(p, k, scheme), 1.0, p.comm_bandwidth_hz,
                                      p.beta_c))


def station_radius_sq(p: Params, k: int, scheme: str, off: frozenset[str] = frozenset()) -> float:
    """Largest rho_k^2 (x-z distance to the station, squared) for which C9-C11 can hold for
    UAV k, with the constraint families in `off` dropped; +inf when nothing limits it, -inf
    when no position can (e.g. static power above P_max).

    With dy2[n] = (y[n] - g_y)^2: rho^2 <= min(P_max / c_k - max dy2,
    E_max,k / (N delta_t c_k) - mean dy2) with E_max,k = p.energy_budget_j(k); static
    power P: rho^2 <= P / c_k - max dy2 (C10 alone) and P <= P_max (C9, independent of the
    position).
    """
    dy2 = (p.y_track - p.ground_station[1]) ** 2
    c = 0.0 if "C10" in off else rate_cost(p, k, scheme)
    if scheme == "static-power":
        power = static_power_w(p)
        if power > p.p_max_w and "C9" not in off:
            return -math.inf  # the fixed schedule itself breaks C9, wherever the UAV is
        return math.inf if c == 0 else _shrunk(power / c - float(dy2.max()), p.nav_error_m)
    if c == 0:
        return math.inf
    peak = math.inf if "C9" in off else p.p_max_w / c - float(dy2.max())
    budget = p.energy_budget_j(k)
    energy = (math.inf if "C11" in off
              else budget / (p.slot_duration_s * p.num_slots * c) - float(dy2.mean()))
    return _shrunk(min(peak, energy), p.nav_error_m)


def _shrunk(r2: float, e: float) -> float:
    """The disk of squared radius r2 with its radius less e (module docstring); -inf when
    nothing is left, r2 itself when e = 0 or the disk is unbounded."""
    if e == 0.0 or r2 == math.inf:
        return r2
    if r2 < 0.0 or math.sqrt(r2) < e:
        return -math.inf
    return (math.sqrt(r2) - e) ** 2


def power_schedule(p: Params, k: int, x: float, z: float, scheme: str) -> np.ndarray:
    """P_com,k[n] for UAV k at (x, z): the cheapest schedule meeting C10 with equality (at
    rho_k + e from the station with a navigation error e, module docstring), or the constant
    E_max/(N delta_t) of the static-power scheme."""
    if scheme == "static-power":
        return np.full(p.num_slots, static_power_w(p))
    if p.nav_error_m == 0.0:
        d = model.distance_to_station(x, p.y_track, z, p.ground_station)
    else:
        rho = math.hypot(x - p.ground_station[0], z - p.ground_station[2]) + p.nav_error_m
        d = np.hypot(rho, p.y_track - p.ground_station[1])
    return model.power_for_rate(planned_rate_bps(p, k, scheme), d, p.comm_bandwidth_hz,
                                p.beta_c)


def schedules(p: Params, formation: np.ndarray, scheme: str) -> np.ndarray:
    """(n, N) schedules for an n-UAV formation; zero rows for UAVs not flown (NaN rows)."""
    out = np.zeros((len(formation), p.num_slots))
    for k in range(len(formation)):
        x, z = formation[k]
        if np.isfinite(x):
            out[k] = power_schedule(p, k, x, z, scheme)
    return out
