"""The tomographic figures of a formation (metrics["tomography"] of every plan with three or
more UAVs flown): the receivers' signed perpendicular baselines about the master
(model.perpendicular_baseline_signed, b_perp,0 = 0), their wavenumbers kappa_k = b_perp,k /
(lambda r_0 sin(theta_0)) (model.elevation_wavenumber, eq. 12's convention), then
array_factor.tomography_figures over |h| <= tomo_height_span_m."""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.tomography.array_factor import tomography_figures

MIN_RECEIVERS = 3  # two receivers are one interferometric pair, not an elevation aperture
# Spans of b_perp below a micrometre (the checker's position tolerance) are no aperture.
APERTURE_MIN_M = 1e-6
NO_APERTURE = "tomography: every receiver has the same b_perp; no elevation aperture"


def wavenumbers(p: Params, formation: np.ndarray, uavs: Sequence[int]) -> np.ndarray:
    """kappa_k [1/m] of the flown UAVs `uavs` (master first, kappa_0 = 0)."""
    q = np.asarray(formation, dtype=float)
    r0 = float(model.slant_range(q[0, 0], q[0, 1], p.x_t))
    b = np.array([float(model.perpendicular_baseline_signed(q[0, 0], q[0, 1], q[k, 0], q[k, 1],
                                                            p.theta0)) for k in uavs])
    return np.asarray(model.elevation_wavenumber(p.wavelength, r0, p.theta0, b), dtype=float)


def plan_tomography(p: Params, formation: np.ndarray, uavs: Sequence[int]
                    ) -> dict[str, Any] | None:
    """The tomographic figures of the flown `uavs` of `formation` with the b_perp,k and the
    array's span of baselines [m]; None with fewer than MIN_RECEIVERS. A formation whose
    receivers all share one b_perp has no aperture: figures None and a `note` saying so."""
    if len(uavs) < MIN_RECEIVERS:
        return None
    kappa = wavenumbers(p, formation, uavs)
    scale = float(model.height_of_ambiguity(p.wavelength, float(model.slant_range(
        formation[0][0], formation[0][1], p.x_t)), p.theta0, 1.0))  # lambda r_0 sin(theta_0)
    out: dict[str, Any] = {"b_perp_signed_m": [float(k * scale) for k in kappa],
                           "aperture_m": float((kappa.max() - kappa.min()) * scale)}
    if out["aperture_m"] < APERTURE_MIN_M:
        return {"height_span_m": p.tomo_height_span_m, **out, "note": NO_APERTURE}
    return {**tomography_figures(kappa, p.tomo_height_span_m).to_dict(), **out}
