"""Planned versus achieved figures of a recorded mission (no ROS import): what `uav-insar
report` prints and plots.

From a MissionRecord (bag/reader.py) and the scenario the mission was flown with (Params):

  per UAV k: the slots reported of N, those below R_min,k - tol (evaluate.rate_tolerance_bps),
    the worst margin min_n (R_k,n - R_min,k), the energy used (the last uav{k}/offload's
    energy_used_j) of the budget (energy_used_j + energy_left_j of that message, else E_max),
    and on the track (the poses from the first slot's start to one slot after the last's) the
    across-track error x - x_k, the height error z - z_k, and the worst of
    sqrt((x - x_k)^2 + (z - z_k)^2);
  the plan's sigma_h (evaluate.evaluate on the recorded formation and power; the planner's own
    figure from /diagnostics beside it) and the sigma_h of the flown geometry: the same
    evaluation with each UAV at its mean (x, z) on the track.

The per-UAV lines are report.flown.summary's, the demo's summary, so both read alike.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uav_insar_planner.bag.reader import MissionRecord
from uav_insar_planner.evaluate import evaluate, rate_tolerance_bps
from uav_insar_planner.params import Params
from uav_insar_planner.report.flown import (
    flown_sigma_h,
    sigma_h_per_slot,
    slot_positions,
    summary,
)
from uav_insar_planner.solver.worst_case import worst_sigma
from uav_insar_planner.swarm import count_problem, uav_name
from uav_insar_planner.swarm import uavs as swarm_uavs


class ReportError(ValueError):
    """The bag lacks what the report needs (one line saying what)."""


@dataclass
class UavTrack:
    """One UAV's poses on the track: t_s, y, dx = x - x_k, dz = z - z_k (arrays)."""

    t_s: np.ndarray
    y: np.ndarray
    dx: np.ndarray
    dz: np.ndarray

    @property
    def worst_error_m(self) -> float:
        return float(np.hypot(self.dx, self.dz).max()) if len(self.dx) else math.nan


@dataclass
class MissionFigures:
    scheme: str
    uavs: list[int]
    num_slots: int
    targets: dict[int, tuple[float, float, float]]  # planned (x_k, y, z_k)
    rates: dict[int, np.ndarray]  # bit/s per slot reported, in order
    applied_w: dict[int, np.ndarray]  # power applied per slot
    energy_j: dict[int, np.ndarray]  # energy used so far, per slot
    budget_j: dict[int, float]
    tracks: dict[int, UavTrack]
    flown_xz: dict[int, tuple[float, float]]  # mean (x, z) on the track
    planned_power_w: np.ndarray  # (num_uavs, N)
    sigma_h_plan_m: float
    sigma_h_recorded_m: float  # the planner's figure on /diagnostics (NaN if none)
    sigma_h_flown_m: float
    sigma_h_worst_m: float  # certified worst case within nav_error_m (NaN at 0)


def _track(poses: np.ndarray | None, offloads: np.ndarray | None,
           target: tuple[float, float, float]) -> UavTrack:
    if poses is None or offloads is None or not len(offloads) or not len(poses):
        return UavTrack(*(np.zeros(0) for _ in range(4)))
    starts = offloads[:, 0]
    slot_s = float(np.median(np.diff(starts))) if len(starts) > 1 else 0.0
    on = (poses[:, 0] >= starts[0]) & (poses[:, 0] <= starts[-1] + slot_s)
    p = poses[on]
    return UavTrack(p[:, 0], p[:, 2], p[:, 1] - target[0], p[:, 3] - target[2])


def flown_scenario(record: MissionRecord, p: Params) -> Params:
    """`p` with num_slots and num_uavs set to the recorded plan's N and number of UAVs when
    they differ (the demo's --num-slots and --uavs): the plan's power says how many slots and
    UAVs were flown. With another num_uavs, rate_min_mbps is R_min,k as the planner reported
    it on /diagnostics (`planner: uavK`, rate_min_bps), else p's for the UAVs p has and its
    last slave's for the others."""
    if record.power is None or record.power.ndim != 2:
        return p
    changes: dict = {}
    if record.power.shape[1] != p.num_slots:
        changes["num_slots"] = int(record.power.shape[1])
    n = int(record.power.shape[0])
    if n != p.num_uavs and count_problem("uavs", n) is None:
        mine = [r / 1e6 for r in p.rate_min_bps]
        changes.update(num_uavs=n, rate_min_mbps=[_recorded_rate_min_mbps(
            record, k, mine[min(k, len(mine) - 1)]) for k in swarm_uavs(n)])
    return p.replace(**changes) if changes else p


def _recorded_rate_min_mbps(record: MissionRecord, k: int, otherwise: float) -> float:
    try:
        value = float(record.uav_values.get(k, {}).get("rate_min_bps", "nan")) / 1e6
    except ValueError:
        return otherwise
    return value if math.isfinite(value) and value >= 0.0 else otherwise


def _plan(record: MissionRecord, p: Params) -> tuple[np.ndarray, np.ndarray, str, list[int]]:
    """The recorded (formation, power, scheme, flown UAVs); ReportError without a plan of
    p.num_uavs UAVs."""
    if record.formation is None or record.power is None:
        raise ReportError("the bag holds no formation and formation/power: was the planner "
                          "running while it recorded?")
    formation, power = record.formation, record.power
    n = formation.shape[0]
    problem = count_problem("the recorded formation", n)
    if problem or power.ndim != 2 or power.shape[0] != n or n != p.num_uavs:
        raise ReportError(problem or f"the recorded plan has {n} poses and power rows "
                          f"{power.shape}; expected {p.num_uavs} of each (num_uavs)")
    scheme = record.plan_values.get("scheme", p.scheme)
    return formation, power, scheme, [k for k in swarm_uavs(n)
                                      if np.isfinite(formation[k]).all()]


def mission_figures(record: MissionRecord, p: Params) -> MissionFigures:
    """The report's figures (see the module docstring); ReportError without a plan."""
    formation, power, scheme, uavs = _plan(record, p)
    targets = {k: tuple(float(v) for v in formation[k]) for k in uavs}
    offloads = {k: record.offloads.get(k, np.zeros((0, 6))) for k in uavs}
    tracks = {k: _track(record.poses.get(k), offloads[k], targets[k]) for k in uavs}
    flown_xz = {k: ((targets[k][0] + float(tracks[k].dx.mean()),
                     targets[k][2] + float(tracks[k].dz.mean()))
                    if len(tracks[k].dx) else (math.nan, math.nan)) for k in uavs}
    budget = {k: (float(offloads[k][-1, 3] + offloads[k][-1, 4]) if len(offloads[k])
                  else p.e_max_j) for k in uavs}
    planned_xz = formation[:, [0, 2]]
    sigma_plan = evaluate(p, planned_xz, power, scheme).sigma_h
    sigma_flown = flown_sigma_h(p, planned_xz, flown_xz, scheme)
    worst = (worst_sigma(p, planned_xz, scheme).upper if p.nav_error_m > 0
             and np.isfinite(planned_xz[uavs]).all() else math.nan)
    try:
        recorded = float(record.plan_values.get("sigma_h_m", "nan"))
    except ValueError:
        recorded = math.nan
    return MissionFigures(
        scheme=scheme, uavs=uavs, num_slots=int(power.shape[1]), targets=targets,
        rates={k: record.rates.get(k, np.zeros((0, 2)))[:, 1] for k in uavs},
        applied_w={k: offloads[k][:, 2] for k in uavs},
        energy_j={k: offloads[k][:, 3] for k in uavs}, budget_j=budget, tracks=tracks,
        flown_xz=flown_xz, planned_power_w=power, sigma_h_plan_m=float(sigma_plan),
        sigma_h_recorded_m=recorded, sigma_h_flown_m=float(sigma_flown), sigma_h_worst_m=worst)


def flown_by_strip(record: MissionRecord, p: Params) -> dict[int, list[tuple[int, float]]]:
    """Each survey strip's slots as flown, (n, sigma_h as flown [m], NaN: unusable), from
    every flown UAV's offload samples grouped by their `strip` field (report/flown.py
    `slot_positions`, `sigma_h_per_slot`; the plan's formation and scheme as recorded).
    ReportError when no sample names a strip: a single pass, or agents that did not name it."""
    formation, _, scheme, uavs = _plan(record, p)
    tol = rate_tolerance_bps(p.rate_min_bps)
    slots = {k: slot_positions(record.offloads.get(k, np.zeros((0, 6))),
                               record.rates.get(k, np.zeros((0, 2))),
                               record.poses.get(k, np.zeros((0, 4))), p.rate_min_bps[k], tol,
                               p.slot_duration_s, p.speed * p.slot_duration_s) for k in uavs}
    slots = {k: {key: q for key, q in flown.items() if key[0] >= 0}
             for k, flown in slots.items()}
    if not any(slots.values()):
        raise ReportError("the bag's uavK/offload samples name no survey strip (strip -1 or no "
                          "strip field): a single pass, which has no survey to map")
    return sigma_h_per_slot(p, formation[:, [0, 2]], scheme, slots)


def report_table(f: MissionFigures, p: Params) -> str:
    """The printed table: the demo's per-UAV summary lines, the worst position errors and
    sigma_h planned versus flown."""
    tol = rate_tolerance_bps(p.rate_min_bps)
    energy = {k: float(f.energy_j[k][-1]) for k in f.uavs if len(f.energy_j[k])}
    rates = {k: list(f.rates[k]) for k in f.uavs}
    budget = max(f.budget_j.values()) if f.budget_j else p.e_max_j
    lines = [summary(f"{f.scheme} plan, {f.num_slots} slots", f.targets, rates, f.num_slots,
                     p.rate_min_bps, tol, None, 0.0, 0.0, energy, budget).lstrip("\n")]
    for k in f.uavs:
        t = f.tracks[k]
        if not len(t.dx):
            lines.append(f"  {uav_name(k)}: no pose on the track")
            continue
        lines.append(f"  {uav_name(k)}: on the track {len(t.dx)} poses, worst position error "
                     f"{t.worst_error_m:.3f} m (across-track {np.abs(t.dx).max():.3f} m, height "
                     f"{np.abs(t.dz).max():.3f} m)")
    recorded = (f" (planner: {f.sigma_h_recorded_m:.4g} m)"
                if math.isfinite(f.sigma_h_recorded_m) else "")
    lines.append(f"  sigma_h: plan {f.sigma_h_plan_m:.4g} m{recorded}, flown geometry "
                 f"{f.sigma_h_flown_m:.4g} m")
    if math.isfinite(f.sigma_h_worst_m):
        held = ("within it" if f.sigma_h_flown_m <= f.sigma_h_worst_m
                else "ABOVE it: a UAV flew beyond the navigation error planned for")
        lines.append(f"  sigma_h: certified worst case within nav_error_m = {p.nav_error_m:g} m "
                     f"{f.sigma_h_worst_m:.4g} m; flown {held}")
    return "\n".join(lines)
