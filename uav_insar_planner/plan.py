"""The planner's answer: formation, power schedules, metrics and the constraint report.

A Plan is plain data (numpy arrays and floats, SI units). `to_dict()` gives the JSON shape the
CLI prints and docs/cli.md documents.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from uav_insar_planner.swarm import uav_name

# Two UAVs planned closer than this may touch once each flies with its own position error:
# standard GNSS (single frequency, SBAS) is good to about 1.5-3 m horizontally (95 %), RTK to
# 0.02-0.05 m. Table I's d_min = 1.5 m therefore needs RTK; 2 m is the warning threshold.
Vec3 = tuple[float, float, float]  # a point or vector, (x, y, z) or (N, E, D); the one alias

SAFE_SEPARATION_M = 2.0


def closest_pair(formation: np.ndarray) -> tuple[float, int, int] | None:
    """(distance, j, k) of the two flown UAVs closest in the across-track plane, j < k; None
    with fewer than two flown (rows of NaN are not flown)."""
    flown = [k for k in range(len(formation)) if np.all(np.isfinite(formation[k]))]
    pairs = [(float(np.hypot(*(formation[j] - formation[k]))), j, k)
             for i, j in enumerate(flown) for k in flown[i + 1:]]
    return min(pairs) if pairs else None


@dataclass
class ConstraintStatus:
    """One constraint family C1..C11: satisfied or not, and its worst slack (>= 0 when met).

    Slack is in the constraint's own SI unit (metres, radians, watts, bit/s, joules or a
    dimensionless coherence), taken over every UAV / pair / slot the constraint covers.
    """

    ok: bool
    slack: float
    detail: str = ""


@dataclass
class Plan:
    """A solved (or infeasible) instance of problem (P).

    formation: (num_uavs, 2) array of (x_k, z_k) in metres, row k = U_k; a row is NaN when
      the scheme does not fly that UAV (single-baseline flies U_0 and U_1 only).
    p_com_w: (num_uavs, N) communication power in watts, P_com[k][n]; zeros for a UAV not flown.
    """

    feasible: bool
    scheme: str
    objective: str
    solver: str
    formation: np.ndarray
    p_com_w: np.ndarray
    sigma_h_m: float
    sigma_h_bound_m: float
    iterations: int
    solve_time_s: float
    constraints: dict[str, ConstraintStatus]
    metrics: dict[str, Any] = field(default_factory=dict)
    blocking_constraints: list[str] = field(default_factory=list)
    lower_bound_m: float = float("nan")
    optimality_gap: float = float("nan")
    certificate: str = ""
    message: str = ""
    #: Navigation error e (solver/robust.py): sigma_h_worst_m is a certified upper bound of
    #: sigma_h with each UAV anywhere within e of its planned point (sigma_h_m at e = 0);
    #: worst_lower_bound_m / worst_gap: a certified lower bound of the worst-case problem and
    #: the gap to it; robust_constraints: each family's least slack over the error disks.
    nav_error_m: float = 0.0
    sigma_h_worst_m: float = float("nan")
    worst_lower_bound_m: float = float("nan")
    worst_gap: float = float("nan")
    worst_certificate: str = ""
    robust_constraints: dict[str, ConstraintStatus] = field(default_factory=dict)

    @property
    def num_uavs(self) -> int:
        """N_UAV, the swarm's size: one formation row per UAV."""
        return len(self.formation)

    @property
    def active_uavs(self) -> list[int]:
        return [k for k in range(self.num_uavs) if np.all(np.isfinite(self.formation[k]))]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (docs/cli.md, 'uav-insar solve --json')."""

        def num(v: float) -> float | None:
            return None if v is None or not np.isfinite(v) else float(v)

        formation = {}
        for k in range(self.num_uavs):
            name = uav_name(k)
            x, z = self.formation[k]
            formation[name] = None if not np.isfinite(x) else {"x_m": float(x), "z_m": float(z)}
        return {
            "feasible": bool(self.feasible),
            "scheme": self.scheme,
            "objective": self.objective,
            "solver": self.solver,
            "sigma_h_m": num(self.sigma_h_m),
            "sigma_h_bound_m": num(self.sigma_h_bound_m),
            "lower_bound_m": num(self.lower_bound_m),
            "optimality_gap": num(self.optimality_gap),
            "certificate": self.certificate,
            "nav_error_m": float(self.nav_error_m),
            "sigma_h_worst_m": num(self.sigma_h_worst_m),
            "worst_lower_bound_m": num(self.worst_lower_bound_m),
            "worst_gap": num(self.worst_gap),
            "worst_certificate": self.worst_certificate,
            "robust_constraints": {
                name: {"ok": bool(c.ok), "slack": num(c.slack), "detail": c.detail}
                for name, c in self.robust_constraints.items()
            },
            "formation": formation,
            "p_com_w": [[float(watts) for watts in row] for row in self.p_com_w],
            "iterations": int(self.iterations),
            "solve_time_s": float(self.solve_time_s),
            "constraints": {
                name: {"ok": bool(c.ok), "slack": num(c.slack), "detail": c.detail}
                for name, c in self.constraints.items()
            },
            "blocking_constraints": list(self.blocking_constraints),
            "metrics": _jsonable(self.metrics),
            "message": self.message,
        }


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (np.floating, float)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value
