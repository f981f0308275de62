"""A formation as the bridge flies it: the poses of a plan cleaned (a UAV not flown is None),
and the planned separations checked against what GNSS can keep apart."""
from __future__ import annotations

import math
from collections.abc import Sequence

from uav_insar_planner.plan import Vec3
from uav_insar_planner.swarm import uav_name


def clean_formation(poses: Sequence[Vec3 | None], count: int) -> list[Vec3 | None]:
    """`count` poses as float tuples; a missing or non-finite pose becomes None (not flown)."""
    clean: list[Vec3 | None] = []
    for k in range(count):
        p = poses[k] if k < len(poses) else None
        ok = p is not None and all(math.isfinite(float(c)) for c in p)
        clean.append(tuple(float(c) for c in p) if ok else None)
    return clean


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
