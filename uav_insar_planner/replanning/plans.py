"""Re-planning in mid-mission: the problem left when a slave is lost or a closed loop
saturates, and its answer mapped back onto the whole mission (no ROS; the planner node calls it).

Lost slave (`remaining_problem`, `full_plan`): from slot n0 on, the master U0 and the
surviving slaves U_s1 < U_s2 < ... fly an (N_UAV - 1)-UAV problem over the N - n0 slots left,
each within the energy it has left. The reduced problem is Params with

    num_uavs' = 1 + #survivors,  reduced row i is mission UAV rows[i] = (0, s1, s2, ...)
    num_slots N' = N - n0,  g_y' = g_y - y[n0]  (the along-track origin moved to slot n0: only
                                                 y[n] - g_y enters the model, so this is exact)
    R_min' = (R_min,0, R_min,s1, ...)  (each survivor keeps its own rate)
    energy_budget_uav_j = (E_left,0, E_left,s1, ...)  (C11 per UAV, `Params.energy_budget_j`)

and the objective and solver of the scenario. Its scheme is the mission's (`reduced_scheme`):
a fixed master stays fixed and a static schedule static; `proposed` with one survivor left is
benchmark 1, single-baseline. `full_plan` maps its answer back: formation rows of the
survivors, the lost slave NaN (as in every Plan, a NaN row is a UAV not flown);
P_com[k][:n0] keeps the schedule flown so far, P_com[k][n0:] is the new one, the lost UAV's row
is zero. The plan's metrics and constraint report are the reduced problem's (the remaining
slots).

Power re-plan (`power_replan`), formation unchanged, for a UAV whose closed loop saturates:
over the slots n >= n0 left, the least power meeting R_min at the planned position over the
link gain g the planner measured (`measured_gain`, at most 1: never less than the model asks),

    P[n] = min(P_max, c_k d_n^2 / g),  then scaled by min(1, E_left / (sum_n P[n] delta_t))

so it never plans more than the energy left (C11) nor above P_max (C9); when the budget is
short every slot left gets the same fraction of its need.

Hold (`hold_plan`): the plan published when the mission cannot continue (the master, or
every slave, lost): every pose NaN and every power zero; an agent whose target turns NaN in
mid-mission holds where it is, and the MAVLink bridge commands LOITER.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.plan import Plan
from uav_insar_planner.solver import solve
from uav_insar_planner.solver.power import power_schedule
from uav_insar_planner.swarm import MASTER, slaves, uav_name


@dataclass(frozen=True)
class ReducedProblem:
    """The problem left after UAV `lost` was lost at slot `first_slot`: `params` (SI, its
    slot 0 is the mission's slot first_slot), flown by the mission's UAVs `rows` (reduced
    row i is UAV rows[i]), in a swarm of `num_uavs` (the mission's)."""

    params: Params
    rows: tuple[int, ...]
    first_slot: int
    lost: int
    num_uavs: int


def energy_left_j(params: Params, power_w: np.ndarray, k: int, first_slot: int) -> float:
    """E_com^max - sum_{n < first_slot} P_com[k][n] delta_t: what UAV k has left when it flew
    the schedule `power_w` (num_uavs, N) up to slot first_slot."""
    used = float(np.sum(np.asarray(power_w, dtype=float)[k, :first_slot]))
    return params.e_max_j - used * params.slot_duration_s


def surviving_slaves(flown: Sequence[int], lost: int) -> tuple[int, ...]:
    """The slaves still flying when `lost` is lost from the UAVs `flown` (empty: none)."""
    return tuple(sorted(k for k in flown if k != MASTER and k != lost))


def reduced_scheme(scheme: str, survivors: Sequence[int]) -> str:
    """The scheme of the problem left: the mission's, `proposed` with one slave left being
    benchmark 1 (single-baseline), the problem it then is."""
    return "single-baseline" if scheme == "proposed" and len(survivors) == 1 else scheme


def remaining_problem(params: Params, lost: int, survivors: Sequence[int], first_slot: int,
                      energy_left: Mapping[int, float]) -> ReducedProblem:
    """The reduced problem of the module doc. ValueError for the master, a slot outside
    0..N-1 or a negative energy (one line naming the value)."""
    team = tuple(slaves(params.num_uavs))
    survivors = tuple(sorted(survivors))
    if lost not in team or not survivors or lost in survivors or any(
            s not in team for s in survivors) or len(set(survivors)) != len(survivors):
        raise ValueError(f"lost: value {lost!r} is not allowed with survivors "
                         f"{list(survivors)!r}; expected a slave ({', '.join(map(str, team))}) "
                         "that is not among the survivors, and at least one survivor")
    if not 0 <= first_slot < params.num_slots:
        raise ValueError(f"first_slot: value {first_slot!r} is not allowed; expected 0.."
                         f"{params.num_slots - 1}")
    rows = (MASTER, *survivors)
    budgets = tuple(float(energy_left[k]) for k in rows)
    if not all(np.isfinite(e) and e > 0.0 for e in budgets):
        raise ValueError(f"energy_left: value {list(budgets)!r} is not allowed; expected "
                         "finite energies > 0 for the master and the survivors")
    gx, gy, gz = params.ground_station
    y0 = first_slot * params.speed * params.slot_duration_s  # y[first_slot], equation (1)
    rate = [params.raw["rate_min_mbps"][k] for k in rows]
    reduced = params.replace(num_uavs=len(rows), num_slots=params.num_slots - first_slot,
                             scheme=reduced_scheme(params.scheme, survivors),
                             ground_station_m=[gx, gy - y0, gz], rate_min_mbps=rate)
    reduced = dataclasses.replace(reduced, energy_budget_uav_j=budgets)
    return ReducedProblem(reduced, rows, first_slot, lost, params.num_uavs)


def full_plan(problem: ReducedProblem, answer: Plan, flown_power_w: np.ndarray) -> Plan:
    """`answer` to `problem` as a plan of the whole mission (see the module doc)."""
    n0, rows = problem.first_slot, problem.rows
    power = np.array(flown_power_w, dtype=float, copy=True)
    formation = np.full((problem.num_uavs, 2), np.nan)
    power[:, n0:] = 0.0
    for i, k in enumerate(rows):
        formation[k] = answer.formation[i]
        power[k, n0:] = answer.p_com_w[i]
    power[problem.lost] = 0.0
    names = {uav_name(i): uav_name(k) for i, k in enumerate(rows)}
    metrics = {key: ({names.get(n, n): v for n, v in value.items()}
                     if isinstance(value, dict) else value)
               for key, value in answer.metrics.items()}
    flyers = [uav_name(k) for k in rows]
    note = (f"re-planned from slot {n0} without {uav_name(problem.lost)}: "
            f"{problem.params.scheme} for {', '.join(flyers[:-1])} and {flyers[-1]}")
    return dataclasses.replace(answer, formation=formation, p_com_w=power, metrics=metrics,
                               message=note + ("; " + answer.message if answer.message else ""))


def replan_without(params: Params, flown_power_w: np.ndarray, lost: int,
                   survivors: Sequence[int], first_slot: int, energy_left: Mapping[int, float]
                   ) -> tuple[Plan, ReducedProblem]:
    """Solve the problem left after slave `lost` was lost at `first_slot` (`solver.solve`,
    checked by the independent evaluator) and map it onto the whole mission."""
    problem = remaining_problem(params, lost, survivors, first_slot, energy_left)
    answer = solve(problem.params)
    return full_plan(problem, answer, flown_power_w), problem


def measured_gain(params: Params, k: int, position: tuple[float, float, float],
                  power_w: float, rate_bps: float) -> float:
    """The channel power gain a slot showed: g = c_k(R) d^2 / P, the power the model needs for
    the rate achieved over the power applied (1 on the paper's link); nan if P <= 0."""
    if power_w <= 0.0:
        return float("nan")
    d = model.distance_to_station(*position, params.ground_station)
    return float(model.power_for_rate(rate_bps, d, params.comm_bandwidth_hz,
                                      params.beta_c)) / power_w


def power_replan(params: Params, plan: Plan, k: int, first_slot: int, energy_left: float,
                 gain: float = 1.0) -> Plan:
    """`plan` with UAV k's power for the slots n >= first_slot re-planned (module doc)."""
    x, z = plan.formation[k]
    gain = min(1.0, gain) if np.isfinite(gain) and gain > 0.0 else 1.0
    need = power_schedule(params, k, float(x), float(z), "proposed")[first_slot:] / gain
    need = np.minimum(need, params.p_max_w)
    total_j = float(need.sum()) * params.slot_duration_s
    if total_j > max(energy_left, 0.0):
        need *= max(energy_left, 0.0) / total_j
    power = np.array(plan.p_com_w, dtype=float, copy=True)
    power[k, first_slot:] = need
    note = (f"power of {uav_name(k)} re-planned from slot {first_slot} with "
            f"{energy_left:.1f} J left, link gain {10 * np.log10(gain):+.1f} dB")
    return dataclasses.replace(plan, p_com_w=power, message=note)


def hold_plan(params: Params, why: str) -> Plan:
    """The plan of a mission that cannot continue: every pose NaN (hold), every power zero."""
    return Plan(feasible=False, scheme=params.scheme, objective=params.objective,
                solver=params.solver, formation=np.full((params.num_uavs, 2), np.nan),
                p_com_w=np.zeros((params.num_uavs, params.num_slots)), sigma_h_m=float("nan"),
                sigma_h_bound_m=float("nan"), iterations=0, solve_time_s=0.0,
                constraints={}, message=why)
