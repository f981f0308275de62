"""What each scheme flies and pays: the rules that the solvers and the checker share.

- "proposed": every UAV U0..U(N-1), every position and every P_com,k[n] free;
- "single-baseline" (benchmark 1): U0 and U1 only;
- "fixed-master" (benchmark 2): q_0 = q0_fixed, the master only allocates P_com,0;
- "static-power" (benchmark 3): P_com,k[n] = E_max / (N delta_t) in every slot.

C10 as planned (`planned_rate_bps`) keeps the rate margin mu (`rate_margin`) on top of R_min,k
where the planner chooses the power; a flown slot is judged against R_min,k itself.
"""
from __future__ import annotations

from uav_insar_planner.params import Params
from uav_insar_planner.swarm import MASTER, slaves, uavs


def active_uavs(scheme: str, num_uavs: int) -> tuple[int, ...]:
    """The UAVs a scheme flies in a swarm of num_uavs: benchmark 1 (single-baseline) flies the
    master and its first slave only."""
    if scheme == "single-baseline":
        return (MASTER, slaves(num_uavs)[0])
    return tuple(uavs(num_uavs))


def slave_uavs(scheme: str, num_uavs: int) -> tuple[int, ...]:
    """The slaves a scheme flies: (1,) for single-baseline, else every slave."""
    return tuple(k for k in active_uavs(scheme, num_uavs) if k != MASTER)


def static_power_w(p: Params) -> float:
    """Benchmark 3's constant power: the energy budget spread evenly, E_max / (N delta_t)."""
    return p.e_max_j / (p.num_slots * p.slot_duration_s)


def planned_rate_bps(p: Params, k: int, scheme: str) -> float:
    """The rate C10 holds for UAV k in a plan of `scheme`: (1 + mu) R_min,k, mu = rate_margin;
    R_min,k for the static-power benchmark, whose fixed power E_max / (N delta_t) cannot buy a
    margin (the paper's benchmark 3 stays as the paper has it)."""
    margin = 0.0 if scheme == "static-power" else p.rate_margin
    return p.rate_min_bps[k] * (1.0 + margin)
