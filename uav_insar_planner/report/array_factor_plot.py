"""The elevation point spread function of a plan: its array factor AF(h) in dB
(`uav-insar plot-formation --psf`), with the main lobe, the sidelobe span and the nearest
ambiguity marked (tomography/array_factor.py; matplotlib's Agg back end)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from uav_insar_planner.params import Params  # noqa: E402
from uav_insar_planner.plan import Plan  # noqa: E402
from uav_insar_planner.tomography.array_factor import array_factor  # noqa: E402
from uav_insar_planner.tomography.plan_figures import wavenumbers  # noqa: E402

FLOOR_DB = -40.0
POINTS = 4001


def plot_array_factor(p: Params, plan: Plan, path: str | Path) -> None:
    """20 log10 AF(h) of `plan`'s flown UAVs over |h| <= 1.25 max(span, ambiguity), the
    figures of metrics["tomography"] in the title; raises ValueError when the plan has no
    tomographic figures (fewer than three UAVs, or no aperture)."""
    t = plan.metrics.get("tomography")
    if not t or t.get("resolution_m") is None:
        raise ValueError("plot-formation --psf: the plan has no elevation aperture "
                         "(three or more UAVs at distinct b_perp are needed)")
    kappa = wavenumbers(p, plan.formation, plan.active_uavs)
    top = 1.25 * max(t["height_span_m"], t["ambiguity_height_m"] or 0.0)
    h = np.linspace(-top, top, POINTS)
    db = 20.0 * np.log10(np.maximum(array_factor(kappa, h), 10.0 ** (FLOOR_DB / 20.0)))
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ax.plot(h, db, color="tab:blue", label="|AF(h)|")
    ax.axvspan(-t["main_lobe_m"], t["main_lobe_m"], color="tab:green", alpha=0.15,
               label="main lobe")
    for s in (-1, 1):
        ax.axvline(s * t["height_span_m"], color="k", ls="--", lw=0.8,
                   label="height span" if s > 0 else None)
        if t["ambiguity_height_m"] is not None:
            ax.axvline(s * t["ambiguity_height_m"], color="tab:red", ls=":",
                       label="nearest ambiguity (AF 0.9)" if s > 0 else None)
    if t["pslr_db"] is not None:
        ax.axhline(t["pslr_db"], color="tab:orange", lw=0.8, label="PSLR")
    pslr = "none" if t["pslr_db"] is None else f"{t['pslr_db']:.1f} dB"
    islr = "none" if t["islr_db"] is None else f"{t['islr_db']:.1f} dB"
    ax.set(xlabel="height h [m]", ylabel="array factor [dB]", ylim=(FLOOR_DB, 3.0),
           title=f"resolution {t['resolution_m']:.3g} m, PSLR {pslr}, ISLR {islr}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
