"""What a flown mission achieved, as the demo prints it (no ROS import): rates per slot,
the MAVLink vehicles' pass against the plan, and a summary; and the sigma_h of the formation
as flown, for a whole pass (`flown_sigma_h`) and slot by slot (`slot_positions`,
`sigma_h_per_slot`: the survey's coverage map). Positions in the track frame [m], rates in
bit/s (Mbit/s only in the printed tables), times in seconds.

A slot as flown, for one UAV: its offload sample (ros/topics.py OFFLOAD_FIELDS, sent at the
slot's start t_n) opens it, the UAV's next sample of the same pass closes it (the last slot of
a pass: one slot duration later, the UAV's median). A pass is a run of samples of one strip
with rising slot numbers: a strip flown again (its attempt 2) starts from slot 0 as a new
pass. The slot's position is the mean (x, z) of the UAV's poses in [t_n, t_n+1) (the last
slot's end included), or, given the slot's length, of its pass's poses on its stretch of
track; it is unusable (None) without a pose there, without its achieved rate (the one sent
with it: the same count of each, else the one recorded within half a slot of t_n), or with
that rate below R_min,k - tol (the checker's tolerance). Its sigma_h as flown is the
planner's evaluation (evaluate.evaluate) of the formation with every flown UAV at its slot's
position; NaN when a flown UAV's slot is
unusable or missing.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.params import Params
from uav_insar_planner.plan import Vec3
from uav_insar_planner.swarm import uav_name

#: A slot as flown: (strip, attempt from 1, slot n); strip -1 for a single pass.
SlotKey = tuple[int, int, int]


@dataclass
class PassRecord:
    """One vehicle on the MAVLink pass: across-track error to its planned (x_k, z_k), worst
    and latest, and its distance along the track from y_start."""

    max_error: float = 0.0
    final_error: float = math.nan
    along_track: float = 0.0


class MavlinkPass:
    """Follows the vehicles' positions against their start points `starts[k]` = (x_k,
    y_start, z_k). The pass begins (`began`, monotonic time) when every vehicle is within
    `capture_radius` of its entry, `run_in_m` before its start point (the bridge's own rule,
    track/trajectory.py); from then on every position updates that vehicle's PassRecord."""

    def __init__(self, starts: dict[int, Vec3], capture_radius: float, run_in_m: float) -> None:
        self.starts = starts
        self.entries = {k: (x, y - run_in_m, z) for k, (x, y, z) in starts.items()}
        self.capture_radius = capture_radius
        self.latest: dict[int, Vec3] = {}
        self.poses = dict.fromkeys(starts, 0)
        self.records = {k: PassRecord() for k in starts}
        self.began: float | None = None

    def update(self, k: int, position: Vec3, now: float) -> None:
        if k not in self.starts:
            return
        self.latest[k] = position
        self.poses[k] += 1
        if self.began is None:
            if len(self.latest) == len(self.starts) and all(
                    math.dist(self.latest[j], entry) <= self.capture_radius
                    for j, entry in self.entries.items()):
                self.began = now
            return
        x, y, z = position
        x_k, y_start, z_k = self.starts[k]
        record = self.records[k]
        record.final_error = math.hypot(x - x_k, z - z_k)
        record.max_error = max(record.max_error, record.final_error)
        record.along_track = y - y_start

    def done(self, now: float, duration: float) -> bool:
        """True once the pass began at least `duration` seconds ago."""
        return self.began is not None and now - self.began >= duration


def rate_table(rates: Mapping[int, Sequence[float]], uavs: Sequence[int],
               rate_min_bps: Sequence[float], tol_bps: float, per_line: int = 10) -> list[str]:
    """Each UAV's rates in Mbit/s, `per_line` slots a line; '!' marks a slot below R_min."""
    rows = []
    for k in uavs:
        rows.append(f"{uav_name(k)} (R_min {rate_min_bps[k] / 1e6:g} Mbit/s)")
        for first in range(0, len(rates[k]), per_line):
            cells = [f"{r / 1e6:6.2f}{'!' if r < rate_min_bps[k] - tol_bps else ' '}"
                     for r in rates[k][first:first + per_line]]
            last = first + len(cells) - 1
            rows.append(f"  {first:3d}-{last:<3d}" + "".join(cells))
    return rows


def mavlink_table(mavlink_pass: MavlinkPass, sysids: Sequence[int],
                  endpoints: Sequence[str]) -> list[str]:
    """One line per vehicle: sysid, endpoint, positions received, planned (x_k, z_k) and the
    last position."""
    rows = ["  uav   sysid  vehicle endpoint         poses   target x, z      last x, y, z"]
    for k, (x_k, _, z_k) in mavlink_pass.starts.items():
        last = mavlink_pass.latest.get(k)
        where = "-" if last is None else " ".join(f"{c:8.3f}" for c in last)
        rows.append(f"  {uav_name(k)}  {sysids[k]:5d}  {endpoints[k]:<24s} "
                    f"{mavlink_pass.poses[k]:5d}  {x_k:8.3f} {z_k:7.3f}  {where}")
    return rows


def summary(plan_message: str | None, targets: Mapping[int, Vec3],
            rates: Mapping[int, Sequence[float]], num_slots: int,
            rate_min_bps: Sequence[float], tol: float, mavlink_pass: MavlinkPass | None,
            plan_time: float, pass_m: float, energy_j: Mapping[int, float] | None = None,
            energy_max_j: float = math.nan) -> str:
    """The plan and, per UAV (targets[k] = planned (x_k, y, z_k)), slots flown, rate met or
    missed, the worst margin and the energy used (`energy_j[k]`, of `energy_max_j`); per
    MAVLink vehicle, its across-track error on the pass and its distance along the track
    (the pass is `pass_m` long)."""
    lines = ["\nsummary"]
    if plan_message:
        lines.append(f"  plan: {plan_message}")
    for k, (x, _, z) in targets.items():
        got = rates[k]
        missed = sum(r < rate_min_bps[k] - tol for r in got)
        worst = min(got) - rate_min_bps[k] if got else float("nan")
        verdict = "rate met in every slot" if got and not missed else f"missed in {missed}"
        used = (energy_j or {}).get(k)
        energy = "" if used is None else f", energy {used:.1f} of {energy_max_j:g} J"
        lines.append(f"  {uav_name(k)}: x={x:8.3f} m z={z:7.3f} m  {len(got)}/{num_slots}"
                     f" slots, {verdict}, worst margin {worst:+.3g} bit/s{energy}")
    mp = mavlink_pass
    if mp is not None and mp.began is None:
        lines.append("  MAVLink: the vehicles never gathered at their start points")
    elif mp is not None:
        lines.append(f"  MAVLink: formation established {mp.began - plan_time:.1f} s after the "
                     f"plan (all within {mp.capture_radius:g} m), then the pass")
        for k, r in mp.records.items():
            lines.append(f"  {uav_name(k)} via MAVLink: across-track error max "
                         f"{r.max_error:.3f} m, final {r.final_error:.3f} m; flew "
                         f"{r.along_track:.1f} m along track (pass {pass_m:.1f} m)")
    return "\n".join(lines)


def flown_sigma_h(p: Params, planned_xz: np.ndarray, flown_xz: Mapping[int, tuple[float, float]],
                  scheme: str) -> float:
    """The fused sigma_h [m] of the formation `planned_xz` ((num_uavs, 2), NaN rows for UAVs
    not flown) with each UAV k of `flown_xz` at its flown (x, z) instead; NaN when one of
    those is not finite. The planner's own evaluation (evaluate.evaluate); sigma_h is the
    geometry's alone (the power enters only C9-C11), so none is given."""
    if not all(math.isfinite(v) for q in flown_xz.values() for v in q):
        return math.nan
    xz = np.array(planned_xz, dtype=float)
    for k, q in flown_xz.items():
        xz[k] = q
    return float(evaluate(p, xz, np.zeros((len(xz), p.num_slots)), scheme).sigma_h)


def _passes(offloads: np.ndarray) -> list[tuple[int, int, np.ndarray]]:
    """(strip, attempt, row indices) of each pass in a UAV's offload rows (module docstring)."""
    passes: list[tuple[int, int, list[int]]] = []
    attempts: dict[int, int] = {}
    for i, (slot, strip) in enumerate(offloads[:, [1, 5]]):
        last = passes[-1] if passes else None
        if last is None or int(strip) != last[0] or slot <= offloads[last[2][-1], 1]:
            attempts[int(strip)] = attempts.get(int(strip), 0) + 1
            passes.append((int(strip), attempts[int(strip)], []))
        passes[-1][2].append(i)
    return [(strip, attempt, np.array(rows)) for strip, attempt, rows in passes]


def slot_positions(offloads: np.ndarray, rates: np.ndarray, poses: np.ndarray,
                   rate_min_bps: float, tol_bps: float, slot_s: float,
                   slot_m: float | None = None) -> dict[SlotKey, tuple[float, float] | None]:
    """One UAV's slots as flown (module docstring): its `offloads` (t, slot, power_w,
    energy_used_j, energy_left_j, strip) rows, `rates` (t, bit/s) and `poses` (t, x, y, z)
    rows, in time order; `slot_s` the slot duration when no pass shows two slots. Each slot's
    mean (x, z), or None where unusable. With `slot_m` (v_y delta_t) a slot's poses are those
    of its pass on its own stretch of track, y in [n slot_m, (n + 1) slot_m): taken after
    the pass before was heard to end and before the next was heard to begin, whatever the
    arrival of its own samples (a lossy radio delivers some in a burst, seconds late). Passes
    are separated by their turns, in which no UAV is on a strip's stretch; only the return to
    the entry of a strip flown again crosses it, on its line."""
    passes = _passes(offloads) if len(offloads) else []
    gaps = np.concatenate([np.diff(offloads[rows, 0]) for _, _, rows in passes] or [[]])
    duration = float(np.median(gaps)) if len(gaps) else slot_s
    by_order = len(rates) == len(offloads)  # one of each per slot, both reliable, in order
    out: dict[SlotKey, tuple[float, float] | None] = {}
    for i, (strip, attempt, rows) in enumerate(passes):
        starts = offloads[rows, 0]
        ends = np.append(starts[1:], starts[-1] + duration)
        # its poses: after the pass before was heard to end, before the next was heard to begin
        lo = offloads[passes[i - 1][2][-1], 0] + duration if i else -math.inf
        hi = offloads[passes[i + 1][2][0], 0] if i + 1 < len(passes) else math.inf
        during = (poses[:, 0] >= lo) & (poses[:, 0] < hi)
        for j, (t0, t1) in enumerate(zip(starts, ends, strict=True)):
            n = int(offloads[rows[j], 1])
            if slot_m is not None:
                on = during & (poses[:, 2] >= n * slot_m) & (poses[:, 2] < (n + 1) * slot_m)
            else:
                last = j == len(starts) - 1
                on = (poses[:, 0] >= t0) & ((poses[:, 0] <= t1) if last else (poses[:, 0] < t1))
            if by_order:
                rate = rates[rows[j], 1]
            else:
                near = np.abs(rates[:, 0] - t0)
                rate = (rates[int(np.argmin(near)), 1]
                        if len(near) and near.min() <= 0.5 * duration else math.nan)
            usable = on.any() and rate >= rate_min_bps - tol_bps  # False for a NaN rate
            out[(strip, attempt, n)] = ((float(poses[on, 1].mean()), float(poses[on, 3].mean()))
                                        if usable else None)
    return out


def sigma_h_per_slot(p: Params, planned_xz: np.ndarray, scheme: str,
                     slots: Mapping[int, Mapping[SlotKey, tuple[float, float] | None]]
                     ) -> dict[int, list[tuple[int, float]]]:
    """Per strip, (n, sigma_h as flown [m]) of each slot any flown UAV flew, passes in order
    (module docstring): `slots[k]` is flown UAV k's `slot_positions`, one entry per UAV the
    plan flies; NaN where one of them has the slot unusable or not at all."""
    keys = sorted({key for flown in slots.values() for key in flown})
    out: dict[int, list[tuple[int, float]]] = {}
    for key in keys:
        where = {k: flown.get(key) for k, flown in slots.items()}
        sigma = (math.nan if any(q is None for q in where.values())
                 else flown_sigma_h(p, planned_xz, where, scheme))
        out.setdefault(key[0], []).append((key[2], sigma))
    return out
