"""The pass every UAV flies in the track frame, and when it starts.

UAV k's target is (x_k, y_start, z_k) until the track starts, then
(x_k, y_start + s(t - t_start + t_offset), z_k) with s from `braked_pass`; a pass that resumes
mid-track (the planner's resume start) has t_offset = its along-track offset / speed, and
holds the targets there until t_start. A pass that starts from a hover (a start the bridge
heard before its instant, or its own capture) ramps up: the target accelerates at RAMP_MPS2
from the start (`ramp_up`), so no vehicle falls behind and catches up faster than v_y; it
then runs v_y / (2 RAMP_MPS2) behind the unramped clock (1.4 s at Table I's 4.3 m/s). The
track starts once every gating UAV is within `capture_radius_m` of its start point (0: at
once), so the formation is established before the pass.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

from uav_insar_planner.plan import Vec3
from uav_insar_planner.swarm import uav_name

# Braking at the end of a finite pass, gentle for a multicopter's position controller.
BRAKE_MPS2 = 1.5
# ... and its mirror at the start: a target that jumped to v_y would leave a hovering copter
# behind, to catch up at v_y + 1-2 m/s (measured in the network lab: 5.5-6 m/s at 4.3).
RAMP_MPS2 = BRAKE_MPS2
# A start heard this long after its instant is still a start from the hover (radio latency);
# later, the vehicle joins a running pass: no ramp.
JOIN_GRACE_S = 0.5


def from_hover(start: float, now: float) -> bool:
    """Whether a start at `start` heard at `now` (one clock) starts the pass from the hover
    (ramped up), rather than joining a running one (JOIN_GRACE_S)."""
    return start >= now - JOIN_GRACE_S


def ramp_delay_s(speed: float) -> float:
    """How far behind an unramped clock a pass ramped up from a hover runs [s]."""
    return ramp_up(speed / RAMP_MPS2, speed)[2] if speed > 0.0 else 0.0


def ramp_up(elapsed: float, speed: float) -> tuple[float, float, float]:
    """(offset, velocity, shift) `elapsed` seconds after a start from rest: RAMP_MPS2 up to
    `speed`, then cruising; shift = how far behind an unramped clock it runs then (seconds)."""
    if speed <= 0.0:
        return 0.0, 0.0, 0.0
    t_ramp = speed / RAMP_MPS2
    if elapsed < t_ramp:
        return 0.5 * RAMP_MPS2 * elapsed * elapsed, RAMP_MPS2 * elapsed, 0.0
    return speed * (elapsed - 0.5 * t_ramp), speed, 0.5 * t_ramp


def braked_pass(elapsed: float, speed: float, duration: float) -> tuple[float, float]:
    """(offset, velocity) of the along-track target `elapsed` seconds into the pass.

    duration 0: cruise at `speed` for ever. Otherwise cruise, then brake at BRAKE_MPS2 (less
    for a short pass) so that the target stops exactly at speed * duration: a target that
    stopped dead would make every vehicle overshoot by v^2 / (2 a_max) and come back.
    """
    if duration <= 0.0:
        return speed * elapsed, speed
    if speed <= 0.0:
        return 0.0, 0.0
    brake_s = min(speed / BRAKE_MPS2, 2.0 * duration)
    decel = speed / brake_s
    t_brake = duration - brake_s / 2.0  # cruise + braking distances add up to speed * duration
    if elapsed <= t_brake:
        return speed * elapsed, speed
    tau = min(elapsed - t_brake, brake_s)
    return speed * t_brake + speed * tau - 0.5 * decel * tau * tau, speed - decel * tau


def clean_formation(poses: Sequence[Vec3 | None], count: int) -> list[Vec3 | None]:
    """`count` poses as float tuples; a missing or non-finite pose becomes None (not flown)."""
    clean: list[Vec3 | None] = []
    for k in range(count):
        p = poses[k] if k < len(poses) else None
        ok = p is not None and all(math.isfinite(float(c)) for c in p)
        clean.append(tuple(float(c) for c in p) if ok else None)
    return clean


class PassTrajectory:
    """The formation and the track clock. Not thread-safe (the bridge holds its lock)."""

    def __init__(self, speed_mps: float, track_duration_s: float):
        self.speed_mps = speed_mps
        self.track_duration_s = track_duration_s
        self.formation: list[Vec3 | None] | None = None
        self.t_start: float | None = None
        self.t_offset = 0.0  # s: how far into the pass t_start is (a resumed pass)
        self.start_wall: float | None = None  # the planner's instant t_start was set from
        self.ramp = True  # the pass starts from a hover at t_start (`ramp_up`)

    def set_formation(self, clean: list[Vec3 | None]) -> bool:
        """Adopt a cleaned formation; True when it restarts a running track (new y_start).

        A formation with the same y_start keeps the track clock running."""
        old = self.formation
        same_start = old is not None and all(
            a is None or b is None or abs(a[1] - b[1]) < 1e-3
            for a, b in zip(old, clean, strict=True))
        self.formation = clean
        if not same_start and self.t_start is not None:
            self.t_start, self.t_offset, self.start_wall = None, 0.0, None
            return True
        return False

    def start_pose(self, uav: int) -> Vec3 | None:
        """UAV `uav`'s start point (x_k, y_start, z_k), None if it is not flown."""
        return None if self.formation is None else self.formation[uav]

    def target(self, uav: int, now: float) -> tuple[Vec3, Vec3] | None:
        """(position, velocity) of UAV `uav` in the track frame at `now`, or None."""
        start = self.start_pose(uav)
        if start is None:
            return None
        x, y, z = start
        if self.t_start is None:
            return (x, y, z), (0.0, 0.0, 0.0)
        if now < self.t_start:  # (a planner's start may lie ahead; a resumed one holds)
            offset, _ = braked_pass(self.t_offset, self.speed_mps, self.track_duration_s)
            return (x, y + offset, z), (0.0, 0.0, 0.0)
        elapsed = now - self.t_start
        if self.ramp:
            ramped, speed, shift = ramp_up(elapsed, self.speed_mps)
            if not shift:  # still accelerating
                base, _ = braked_pass(self.t_offset, self.speed_mps, self.track_duration_s)
                return (x, y + base + ramped, z), (0.0, speed, 0.0)
            elapsed -= shift
        offset, speed = braked_pass(elapsed + self.t_offset, self.speed_mps,
                                    self.track_duration_s)
        return (x, y + offset, z), (0.0, speed, 0.0)


def too_close(formation: Sequence[Vec3 | None], min_separation_m: float
              ) -> list[tuple[int, int, float]]:
    """Every pair (j, k, distance) of flown UAVs planned closer than `min_separation_m`
    (0: no check). Their positions are only as good as their GNSS (see plan
    SAFE_SEPARATION_M), so a plan below that figure risks a collision."""
    out = []
    for j in range(len(formation)):
        for k in range(j + 1, len(formation)):
            a, b = formation[j], formation[k]
            if a is not None and b is not None and min_separation_m > 0.0:
                d = math.dist(a, b)
                if d < min_separation_m:
                    out.append((j, k, d))
    return out


def separation(formation: Sequence[Vec3 | None], min_separation_m: float
               ) -> tuple[list[str], list[str]]:
    """`too_close` told: (per UAV, "D m from uavK" for each UAV it is too close to, "; "
    joined; a warning line per pair)."""
    notes = [""] * len(formation)
    warnings = []
    for j, k, d in too_close(formation, min_separation_m):
        for a, b in ((j, k), (k, j)):
            notes[a] = (notes[a] + "; " if notes[a] else "") + f"{d:.2f} m from {uav_name(b)}"
        warnings.append(f"{uav_name(j)} and {uav_name(k)} are planned {d:.2f} m apart, closer than "
                        f"min_separation_m {min_separation_m:g} m (standard GNSS is good to "
                        "~1.5-3 m; RTK needed)")
    return notes, warnings
