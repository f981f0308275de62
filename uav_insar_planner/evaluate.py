"""Independent evaluation of a formation and power schedule: metrics and constraints C1..C11.

Built only from `model` (the paper's equations), never from a solver's convex surrogates, so
it can judge any plan. Which UAVs count and what they pay is the scheme's rule (`schemes`):
single-baseline flies U0 and U1 only; static-power requires P_com,k[n] = E_max / (N delta_t)
in every slot.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.plan import ConstraintStatus
from uav_insar_planner.schemes import active_uavs, planned_rate_bps, slave_uavs, static_power_w
from uav_insar_planner.swarm import uav_name
from uav_insar_planner.tomography.plan_figures import plan_tomography

# Relative feasibility tolerance: a constraint counts as met when its slack is at least
# -FEAS_TOL times the constraint's own scale (numerical solvers stop at ~1e-8 accuracy).
FEAS_TOL = 1e-6
# Positions (C1 altitudes, C4 distances) are judged absolutely: a micrometre, far below any
# positioning error, whatever z_max or d_min is (1e-6 z_max let z = -5 m pass at z_max = 1e9).
POSITION_TOL_M = 1e-6


@dataclass
class Evaluation:
    """Metrics of one plan and the status of each constraint family."""

    sigma_h: float
    sigma_h_bound: float
    metrics: dict[str, Any]
    constraints: dict[str, ConstraintStatus]

    @property
    def feasible(self) -> bool:
        return all(c.ok for c in self.constraints.values())

    @property
    def violated(self) -> list[str]:
        return [n for n, c in self.constraints.items() if not c.ok]


def pair_metrics(p: Params, q0: np.ndarray, qk: np.ndarray) -> dict[str, float]:
    """Interferometric metrics of the pair (U0, Uk) at formation rows q0 = (x0, z0), qk."""
    gm = model.gamma_m(p)
    r0 = float(model.slant_range(q0[0], q0[1], p.x_t))
    rk = float(model.slant_range(qk[0], qk[1], p.x_t))
    theta_k = float(model.look_angle(qk[0], qk[1], p.x_t))
    b_perp = float(model.perpendicular_baseline(q0[0], q0[1], qk[0], qk[1], p.theta0))
    snr0 = float(model.snr_monostatic(r0, gm))
    snrk = float(model.snr_bistatic(r0, rk, gm))
    g_snr = float(model.coherence_snr(snr0, snrk))
    bp = p.fractional_bandwidth
    g_rg = float(model.coherence_baseline(model.chi(p.theta0, theta_k), bp))
    g = float(model.coherence_total(g_rg, g_snr, p.coherence_other))
    h_amb = float(model.height_of_ambiguity(p.wavelength, r0, p.theta0, b_perp))
    sigma_phi = float(model.phase_error_crb(g, p.looks))
    return {
        "b_m": float(model.baseline(q0[0], q0[1], qk[0], qk[1])),
        "b_perp_m": b_perp,
        "h_amb_m": h_amb,
        "coherence_baseline": g_rg,
        "coherence_snr": g_snr,
        "coherence_total": g,
        "snr_master": snr0,
        "snr_slave": snrk,
        "phase_error_rad": sigma_phi,
        "sigma_h_m": float(model.height_error(h_amb, sigma_phi)),
    }


def _status(slacks: dict[str, float], scale: float, absolute: float | None = None
            ) -> ConstraintStatus:
    name, worst = min(slacks.items(), key=lambda kv: kv[1])
    tol = FEAS_TOL * scale if absolute is None else absolute
    return ConstraintStatus(bool(worst >= -tol), float(worst), name)


def position_constraints(p: Params, formation: np.ndarray, uavs: Sequence[int]
                         ) -> dict[str, ConstraintStatus]:
    """C1 (every altitude in [z_min, z_max]) and C4 (every two UAVs at least d_min apart) of
    the rows `uavs` of `formation`: what any formation must meet to be flown at all, planned
    or given (`uav-insar export-mission --formation`). The detail names the worst: `zK`, `dIJ`."""
    q = np.asarray(formation, dtype=float)
    c = {"C1": _status({f"z{k}": min(q[k, 1] - p.z_min, p.z_max - q[k, 1]) for k in uavs},
                       1.0, POSITION_TOL_M)}
    c["C4"] = _status({f"d{i}{j}": float(np.hypot(*(q[i] - q[j]))) - p.d_min
                        for i in uavs for j in uavs if i < j}, 1.0, POSITION_TOL_M)
    return c


def evaluate(p: Params, formation: np.ndarray, p_com: np.ndarray, scheme: str,
             objective: str = "exact") -> Evaluation:
    """Metrics and C1..C11 for `formation` ((num_uavs, 2) rows (x_k, z_k), NaN rows for UAVs the
    scheme does not fly) and `p_com` ((num_uavs, N) watts). `objective` multilook adds the
    multilook figures (metrics["multilook"]: exact phase std per pair, fused sigma_h) from
    this check's coherences and h_amb, never the back end's."""
    q = np.asarray(formation, dtype=float)
    power = np.asarray(p_com, dtype=float)
    uavs = active_uavs(scheme, p.num_uavs)
    slaves = slave_uavs(scheme, p.num_uavs)
    pairs = {k: pair_metrics(p, q[0], q[k]) for k in slaves}

    sig = [pairs[k]["sigma_h_m"] for k in slaves]
    sigma_h = float(model.fused_height_error(*sig))
    r0 = float(model.slant_range(q[0, 0], q[0, 1], p.x_t))
    bsq = sum(pairs[k]["b_perp_m"] ** 2 for k in slaves)
    bound = float(model.height_error_bound(p.wavelength, r0, p.theta0, bsq,
                                           model.worst_case_coherence(p), p.looks))

    ranges = {k: float(model.slant_range(q[k, 0], q[k, 1], p.x_t)) for k in uavs}
    looks = {k: (p.theta0 if k == 0 else float(model.look_angle(q[k, 0], q[k, 1], p.x_t)))
             for k in uavs}
    swaths = {k: float(model.swath_width(ranges[k], looks[k], p.beamwidth)) for k in uavs}
    y = p.y_track
    rates = {k: model.fdma_rate(power[k], model.distance_to_station(q[k, 0], y, q[k, 1],
                                                                    p.ground_station),
                                p.comm_bandwidth_hz, p.beta_c) for k in uavs}

    position = position_constraints(p, q, uavs)
    c: dict[str, ConstraintStatus] = {"C1": position["C1"]}
    c["C2"] = _status({"x0": -abs(q[0, 0] - float(model.master_x(q[0, 1], p.x_t, p.theta0)))},
                      1.0)
    c["C3"] = _status({f"theta{k}": min(looks[k] - p.theta_min, p.theta_max - looks[k])
                       for k in slaves}, 1.0)
    c["C4"] = position["C4"]
    c["C5"] = _status({f"S{k}": swaths[k] - p.swath_min for k in uavs}, max(p.swath_min, 1.0))
    c["C6"] = _status({f"gamma_snr{k}": pairs[k]["coherence_snr"] - p.coherence_snr_min
                       for k in slaves}, 1.0)
    c["C7"] = _status({f"gamma_rg{k}": pairs[k]["coherence_baseline"] - p.coherence_rg_min
                       for k in slaves}, 1.0)
    # C8 per slave against its own rung (h_amb_ratio's ladder; all equal at ratio 1)
    # (tolerance scaled by the lowest rung, h_amb^min: the strictest for every slave)
    c["C8"] = _status({f"h_amb{k}": pairs[k]["h_amb_m"] - model.h_amb_min_of(p, k)
                       for k in slaves}, p.h_amb_min)
    c["C9"] = _status({f"P{k}": float(min(power[k].min(), p.p_max_w - power[k].max()))
                       for k in uavs}, max(p.p_max_w, 1e-9))
    # C10 as planned: the rate margin on top of R_min,k (schemes.planned_rate_bps)
    planned = {k: planned_rate_bps(p, k, scheme) for k in uavs}
    c["C10"] = _status({f"R{k}": float((rates[k] - planned[k]).min()) for k in uavs},
                       max(max(planned.values()), 1.0))
    c["C11"] = _status({f"E{k}": p.energy_budget_j(k) - float(power[k].sum()
                                                              * p.slot_duration_s)
                       for k in uavs}, p.e_max_j)
    if scheme == "static-power":
        dev = max(float(np.abs(power[k] - static_power_w(p)).max()) for k in uavs)
        c["C9"].detail += f"; static schedule deviation {dev:.3g} W"
        if dev > FEAS_TOL * max(static_power_w(p), 1e-9):
            c["C9"] = ConstraintStatus(False, -dev, "static schedule")

    metrics = {
        "pairs": {uav_name(k): pairs[k] for k in slaves},
        "slant_range_m": {uav_name(k): ranges[k] for k in uavs},
        "look_angle_deg": {uav_name(k): float(np.degrees(looks[k])) for k in uavs},
        "swath_m": {uav_name(k): swaths[k] for k in uavs},
        "min_rate_mbps": {uav_name(k): float(rates[k].min() / 1e6) for k in uavs},
        "energy_j": {uav_name(k): float(power[k].sum() * p.slot_duration_s) for k in uavs},
    }
    tomography = plan_tomography(p, q, uavs)
    if tomography is not None:
        metrics["tomography"] = tomography
    if objective == "tomography":
        c["C8"] = tomography_requirement(p, tomography)
    if objective == "multilook":
        from uav_insar_planner.multilook import plan_metrics  # scipy: not in a lean install

        metrics["multilook"] = plan_metrics(metrics["pairs"], p.looks)
    return Evaluation(sigma_h, bound, metrics, c)


def tomography_requirement(p: Params, t: dict[str, Any] | None) -> ConstraintStatus:
    """C8 under the tomography objective: the array's nearest ambiguity >= tomo_ambiguity_min_m
    and its resolution at most tomo_resolution_m (the per-pair h_amb limit gives way to them);
    the slack is the smaller of the two margins [m]."""
    if not t or t.get("resolution_m") is None:
        return ConstraintStatus(False, -math.inf, "no elevation aperture")
    amb = t["ambiguity_height_m"] if t["ambiguity_height_m"] is not None else math.inf
    slacks = {"ambiguity": amb - p.tomo_ambiguity_min_m,
              "resolution": p.tomo_resolution_m - t["resolution_m"]}
    return _status(slacks, max(p.tomo_resolution_m, 1.0))


def rate_tolerance_bps(rate_min_bps: tuple[float, ...]) -> float:
    """Shortfall still counted as meeting R_min: the checker's C10 tolerance."""
    return FEAS_TOL * max(max(rate_min_bps), 1.0)
