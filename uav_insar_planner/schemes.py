"""What each scheme flies and pays: the rules that the solvers and the checker share.

- "proposed": U0, U1, U2, every position and every P_com,k[n] free;
- "single-baseline" (benchmark 1): U0 and U1 only;
- "fixed-master" (benchmark 2): q_0 = q0_fixed, the master only allocates P_com,0;
- "static-power" (benchmark 3): P_com,k[n] = E_max / (N delta_t) in every slot.
"""
from __future__ import annotations

from uav_insar_planner.params import Params
from uav_insar_planner.swarm import MASTER, NUM_UAVS, SLAVES


def active_uavs(scheme: str, num_uavs: int = NUM_UAVS) -> tuple[int, ...]:
    """The UAVs a scheme flies out of a swarm of `num_uavs`: benchmark 1 (single-baseline)
    flies the master and its first slave only."""
    return (MASTER, SLAVES[0]) if scheme == "single-baseline" else tuple(range(num_uavs))


def slave_uavs(scheme: str, num_uavs: int = NUM_UAVS) -> tuple[int, ...]:
    """The slaves a scheme flies: (1,) for single-baseline, else every slave."""
    return tuple(k for k in active_uavs(scheme, num_uavs) if k != MASTER)


def static_power_w(p: Params) -> float:
    """Benchmark 3's constant power: the energy budget spread evenly, E_max / (N delta_t)."""
    return p.e_max_j / (p.num_slots * p.slot_duration_s)
