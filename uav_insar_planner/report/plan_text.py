"""A Plan as text for the terminal (`uav-insar solve`); published.py is what the
planner publishes."""
from __future__ import annotations

import numpy as np

from uav_insar_planner.plan import Plan
from uav_insar_planner.swarm import uav_name

CONSTRAINT_TEXT = {
    "C1": "altitude z_min <= z_k <= z_max",
    "C2": "master on its look-angle line",
    "C3": "slave look angle in [theta_min, theta_max]",
    "C4": "UAV separation >= d_min",
    "C5": "swath >= S_min",
    "C6": "SNR coherence >= gamma_SNR^min",
    "C7": "baseline coherence >= gamma_Rg^min",
    "C8": "height of ambiguity >= h_amb,k^min = h_amb^min h_amb_ratio^(k-1)",
    "C9": "0 <= P_com <= P_max",
    "C10": "rate >= (1 + rate_margin) R_min in every slot",
    "C11": "energy <= E_max",
}

TOMOGRAPHY_C8 = ("in its place (objective tomography): the array's nearest ambiguity >= "
                 "tomo_ambiguity_min_m, resolution <= tomo_resolution_m")


def format_plan(plan: Plan) -> str:
    """Multi-line summary: formation, schedules, accuracy, per-pair metrics, constraints."""
    lines = [f"scheme {plan.scheme}, objective {plan.objective}, solver {plan.solver}: "
             + ("FEASIBLE" if plan.feasible else "INFEASIBLE")
             + f"  ({plan.iterations} iterations, {plan.solve_time_s * 1e3:.1f} ms)"]
    if plan.message:
        lines.append(f"note: {plan.message}")
    if not plan.feasible and plan.blocking_constraints:
        lines.append("blocked by: " + ", ".join(
            f"{c} ({CONSTRAINT_TEXT.get(c, c)})" for c in plan.blocking_constraints))
    if not plan.constraints:
        return "\n".join(lines)
    m = plan.metrics
    lines += ["", "formation (across-track plane, metres; target line at x_t, z = 0):",
              "  uav    role      x_m       z_m   range_m  look_deg  swath_m  "
              "P_com min/mean/max W   energy_J"]
    for k, name in enumerate(map(uav_name, range(plan.num_uavs))):
        x, z = plan.formation[k]
        if not np.isfinite(x):
            lines.append(f"  {name}  (not flown by this scheme)")
            continue
        pk = plan.p_com_w[k]
        lines.append(
            f"  {name}  {'master' if k == 0 else 'slave '}  {x:8.3f}  {z:8.3f}  "
            f"{m['slant_range_m'][name]:7.2f}  {m['look_angle_deg'][name]:8.3f}  "
            f"{m['swath_m'][name]:7.2f}  {pk.min():6.3f}/{pk.mean():6.3f}/{pk.max():6.3f}"
            f"   {m['energy_j'][name]:8.2f}")
    lines += ["", f"fused height error sigma_h      = {plan.sigma_h_m:.6f} m",
              f"Proposition-1 bound             = {plan.sigma_h_bound_m:.6f} m"]
    if "multilook" in m:
        ml = m["multilook"]
        per = ", ".join(f"U0-{k[-1]} {v['sigma_h_m']:.6f}" for k, v in ml["pairs"].items())
        lines.append(f"sigma_h, exact multilook phase = {ml['sigma_h_m']:.6f} m (the objective; "
                     f"per pair {per})")
    if np.isfinite(plan.lower_bound_m):
        lines.append(f"certified lower bound           = {plan.lower_bound_m:.6f} m "
                     f"(gap {plan.optimality_gap:.2e}; {plan.certificate})")
    if "tomography_objective" in m:
        t = m["tomography_objective"]
        lines.append(f"tomographic objective: ISLR {t['islr_db']:.3f} dB; {plan.certificate}")
    if plan.nav_error_m > 0:
        lines += robust_lines(plan)
    if "tomography" in m:
        lines += tomography_lines(m["tomography"])
    lines += ["", "interferometric pairs:",
              "  pair       b_m  b_perp_m  h_amb_m  coh_Rg  coh_SNR  coh_tot  SNR_0  SNR_k  "
              "sigma_hk_m"]
    for name, pm in m["pairs"].items():
        lines.append(
            f"  U0-{name[-1]}  {pm['b_m']:8.3f}  {pm['b_perp_m']:8.3f}  {pm['h_amb_m']:7.3f}  "
            f"{pm['coherence_baseline']:6.4f}  {pm['coherence_snr']:7.4f}  "
            f"{pm['coherence_total']:7.4f}  {pm['snr_master']:5.2f}  {pm['snr_slave']:5.2f}  "
            f"{pm['sigma_h_m']:.6f}")
    lines += ["", "constraints (slack >= 0 when met; SI units):"]
    for name, c in plan.constraints.items():
        text = TOMOGRAPHY_C8 if name == "C8" and "tomography_objective" in m else (
            CONSTRAINT_TEXT[name])
        lines.append(f"  {name:<4} {'ok  ' if c.ok else 'FAIL'}  slack {c.slack:12.6g}  "
                     f"[{c.detail}]  {text}")
    if plan.robust_constraints:
        lines += ["", f"worst case over the error disks (every UAV within {plan.nav_error_m:g} m; "
                  "least slack, exact or conservative):"]
        for name, c in plan.robust_constraints.items():
            lines.append(f"  {name:<4} {'ok  ' if c.ok else 'FAIL'}  slack {c.slack:12.6g}  "
                         f"[{c.detail}]")
    return "\n".join(lines)


def robust_lines(plan: Plan) -> list[str]:
    """The worst case of a robust plan (nav_error_m > 0): sigma_h_worst_m and its gap."""
    gap = (f"gap {plan.worst_gap:.2%} to {plan.worst_lower_bound_m:.6f} m, the larger of two "
           "relaxations' certified bounds" if np.isfinite(plan.worst_gap)
           else "no lower bound for this objective")
    return [f"worst case, nav error {plan.nav_error_m:g} m = {plan.sigma_h_worst_m:.6f} m "
            f"(certified upper bound of sigma_h with every UAV anywhere within "
            f"{plan.nav_error_m:g} m; {gap}; {plan.worst_certificate})"]


def tomography_lines(t: dict) -> list[str]:
    """The array's tomographic figures (metrics["tomography"], tomography/plan_figures.py)."""
    def metres(v: float | None) -> str:
        return "none" if v is None else f"{v:.4g} m"

    b = ", ".join(f"{v:.3f}" for v in t["b_perp_signed_m"])
    head = f"tomography (SIMO array, b_perp {b} m; sidelobes over |h| <= {t['height_span_m']:g} m):"
    if "note" in t:
        return ["", head, f"  {t['note']}"]
    pslr = "no sidelobe in the span" if t["pslr_db"] is None else (
        f"PSLR {t['pslr_db']:.2f} dB, ISLR {t['islr_db']:.2f} dB")
    return ["", head,
            f"  Rayleigh resolution {metres(t['resolution_m'])}, main lobe to "
            f"{metres(t['main_lobe_m'])}, nearest ambiguity (AF >= 0.9) "
            f"{metres(t['ambiguity_height_m'])} (searched to {t['ambiguity_search_m']:.4g} m)",
            f"  {pslr}"]
