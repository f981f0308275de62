"""What a flown mission achieved, as the demo prints it (no ROS import): rates per slot,
the MAVLink vehicles' pass against the plan, and a summary. Positions in the track frame [m],
rates in bit/s (Mbit/s only in the printed tables)."""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from uav_insar_planner.plan import Vec3
from uav_insar_planner.swarm import uav_name


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
