"""Pure content of the planner's messages: Plan -> /formation, /formation/power, /diagnostics.

Nothing here imports ROS; the planner node copies these plain values into messages. Units are
SI throughout (metres, watts, bit/s, seconds).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from uav_insar_planner.evaluate import rate_tolerance_bps
from uav_insar_planner.plan import Plan
from uav_insar_planner.swarm import uav_index, uav_name

# diagnostic_msgs/DiagnosticStatus levels.
OK, WARN, ERROR, STALE = 0, 1, 2, 3
LEVEL_NAMES = {OK: "OK", WARN: "WARN", ERROR: "ERROR", STALE: "STALE"}

HARDWARE_ID = "uav_insar_planner"
BRIDGE_STATUS_PREFIX = "mavlink_bridge: "  # + the UAV's name: the bridge's per-vehicle status


def bridge_status_name(k: int) -> str:
    """The MAVLink bridge's status of vehicle k, e.g. `mavlink_bridge: uav1`."""
    return BRIDGE_STATUS_PREFIX + uav_name(k)


def bridge_status_uav(name: str) -> int | None:
    """The UAV a `bridge_status_name` names; None for any other status."""
    rest = name[len(BRIDGE_STATUS_PREFIX):] if name.startswith(BRIDGE_STATUS_PREFIX) else ""
    return uav_index(rest) if rest else None


def bridge_cannot_fly(values: dict[str, str], message: str) -> str:
    """Why a bridge status (its values by key, its message) says its UAV cannot fly the pass
    any more, "" when it does not: the link `lost`, or `out_of_control` (a failsafe, a pilot:
    mavlink/control_states.py). The one rule the planner's swarm watch declares a UAV lost
    by from its bridge (`behind`, a hold the swarm may resume from, is ros/start_states.py's)."""
    if values.get("out_of_control"):
        return values["out_of_control"]
    return message if values.get("link") == "lost" else ""
PLAN_STATUS_NAME = "planner: plan"
POSITION_ERROR_KEY = "position_error_m"  # a uav_status value: |(x, z) - (x_k, z_k)| [m]


def uav_status_name(k: int) -> str:
    """The planner's status of UAV k on /diagnostics, e.g. `planner: uav1` (`uav_status`)."""
    return f"planner: {uav_name(k)}"


@dataclass
class Status:
    """One diagnostic_msgs/DiagnosticStatus, as plain values."""

    level: int
    name: str
    message: str
    values: list[tuple[str, str]] = field(default_factory=list)
    hardware_id: str = HARDWARE_ID


def fmt(value: float) -> str:
    """A number as a diagnostics value string: 6 significant digits, 'nan' when not finite."""
    return f"{value:.6g}" if math.isfinite(value) else "nan"


def formation_points(plan: Plan) -> list[tuple[float, float, float]]:
    """poses[k] = (x_k, y_start = 0, z_k) for k = 0 (master), 1, .., num_uavs - 1.

    A UAV the scheme does not fly (single-baseline's U2) keeps NaN x and z, so poses[k]
    always means U_k.
    """
    return [(float(x), 0.0, float(z)) for x, z in plan.formation]


def power_rows(plan: Plan) -> tuple[int, int, list[float]]:
    """(num_uavs, N, P_com[k][n] row-major in watts) for a Float64MultiArray with dims
    [uav, slot]."""
    p = np.asarray(plan.p_com_w, dtype=float)
    return int(p.shape[0]), int(p.shape[1]), [float(v) for v in p.ravel()]


def plan_status(plan: Plan) -> Status:
    """The plan's diagnostics: OK when feasible, ERROR (naming the blocking constraints) if not."""
    values = [
        ("scheme", plan.scheme),
        ("objective", plan.objective),
        ("solver", plan.solver),
        ("feasible", str(plan.feasible).lower()),
        ("sigma_h_m", fmt(plan.sigma_h_m)),
        ("sigma_h_bound_m", fmt(plan.sigma_h_bound_m)),
        ("lower_bound_m", fmt(plan.lower_bound_m)),
        ("optimality_gap", fmt(plan.optimality_gap)),
        ("nav_error_m", fmt(plan.nav_error_m)),
        ("sigma_h_worst_m", fmt(plan.sigma_h_worst_m)),
        ("worst_gap", fmt(plan.worst_gap)),
    ]
    for name, pair in sorted(plan.metrics.get("pairs", {}).items()):
        values += [
            (f"b_perp_m.{name}", fmt(pair["b_perp_m"])),
            (f"h_amb_m.{name}", fmt(pair["h_amb_m"])),
            (f"coherence.{name}", fmt(pair["coherence_total"])),
        ]
    for k, (x, _, z) in enumerate(formation_points(plan)):
        values += [(f"x_m.{uav_name(k)}", fmt(x)), (f"z_m.{uav_name(k)}", fmt(z))]
    values += [
        ("solve_time_s", fmt(plan.solve_time_s)),
        ("iterations", str(plan.iterations)),
        ("blocking_constraints", ",".join(plan.blocking_constraints)),
    ]
    if plan.feasible:
        worst = (f", worst case {plan.sigma_h_worst_m:.4g} m within {plan.nav_error_m:g} m"
                 if plan.nav_error_m > 0 else "")
        message = (f"{plan.scheme} plan: sigma_h {plan.sigma_h_m:.4g} m "
                   f"(bound {plan.sigma_h_bound_m:.4g} m{worst}), solved in "
                   f"{plan.solve_time_s:.3g} s")
        return Status(OK, PLAN_STATUS_NAME, message, values)
    blocking = ", ".join(plan.blocking_constraints) or "unknown"
    message = f"{plan.scheme}: infeasible, blocked by {blocking}; not published"
    if plan.message:
        message += f" ({plan.message})"
    return Status(ERROR, PLAN_STATUS_NAME, message, values)


def failure_status(scheme: str, error: str) -> Status:
    """ERROR status for a solve that raised instead of returning a plan."""
    return Status(ERROR, PLAN_STATUS_NAME, f"{scheme}: solve failed: {error}",
                  [("scheme", scheme), ("feasible", "false")])


@dataclass
class UavReport:
    """What the planner last heard from one agent (None until heard)."""

    position: tuple[float, float, float] | None = None
    rate_bps: float | None = None
    rate_count: int = 0
    min_margin_bps: float = math.inf

    def record_rate(self, rate_bps: float, rate_min_bps: float) -> None:
        """Keep the latest rate and the worst margin seen since the last plan."""
        self.rate_bps = rate_bps
        self.rate_count += 1
        self.min_margin_bps = min(self.min_margin_bps, rate_bps - rate_min_bps)


def uav_status(k: int, target_xz: tuple[float, float], rate_min_bps: tuple[float, ...],
               report: UavReport) -> Status:
    """Per-UAV diagnostics: rate margin (achieved - R_min,k) and across-track position error.

    WARN when the last achieved rate misses R_min,k by more than the checker's tolerance;
    STALE until the agent has reported both a pose and a rate.
    """
    name = uav_status_name(k)
    values = [("rate_min_bps", fmt(rate_min_bps[k])),
              ("target_x_m", fmt(target_xz[0])), ("target_z_m", fmt(target_xz[1]))]
    if report.position is None or report.rate_bps is None:
        return Status(STALE, name, "no pose and rate reported yet", values)
    x, y, z = report.position
    error = math.hypot(x - target_xz[0], z - target_xz[1])
    margin = report.rate_bps - rate_min_bps[k]
    values += [
        ("achieved_rate_bps", fmt(report.rate_bps)),
        ("rate_margin_bps", fmt(margin)),
        ("min_rate_margin_bps", fmt(report.min_margin_bps)),
        ("slots_reported", str(report.rate_count)),
        (POSITION_ERROR_KEY, fmt(error)),
        ("y_m", fmt(y)),
    ]
    text = (f"rate margin {margin / 1e6:+.4g} Mbit/s, position error {error:.3g} m")
    if margin < -rate_tolerance_bps(rate_min_bps):
        return Status(WARN, name, "rate target missed: " + text, values)
    return Status(OK, name, text, values)
