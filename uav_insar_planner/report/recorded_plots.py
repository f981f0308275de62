"""The mission report's PNGs (matplotlib, Agg back end, as figures.py): one figure per quantity,
one panel per flown UAV, planned or required dashed, achieved solid.

  report_rate.png       achieved rate per slot against R_min,k [Mbit/s]
  report_power.png      applied against planned P_com,k[n] [W]
  report_energy.png     energy used so far against the budget E_com^max [J]
  report_error.png      across-track (x - x_k) and height (z - z_k) error along the track [m]
  report_formation.png  the across-track plane: planned positions, the flown ones (each pose on
                        the track), the target line and the ground station
"""
from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from uav_insar_planner.params import Params  # noqa: E402
from uav_insar_planner.report.recorded import MissionFigures  # noqa: E402
from uav_insar_planner.swarm import uav_color, uav_name  # noqa: E402

FILES = ("report_rate.png", "report_power.png", "report_energy.png", "report_error.png",
         "report_formation.png")
PANELS_PER_ROW = 3  # up to nine UAVs; a larger swarm takes a squarer grid (ten: 4 x 3)


def _panels(f: MissionFigures, title: str):
    """A panel per flown UAV, PANELS_PER_ROW a row, or ceil(sqrt(n)) a row when that is more
    (n flown UAVs)."""
    cols = min(len(f.uavs), max(PANELS_PER_ROW, math.ceil(math.sqrt(len(f.uavs)))))
    rows = -(-len(f.uavs) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.2 * rows), squeeze=False)
    fig.suptitle(title, fontsize=10)
    flat = list(axes.ravel())
    for spare in flat[len(f.uavs):]:
        spare.set_visible(False)
    return fig, dict(zip(f.uavs, flat, strict=False))


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def plot_report(f: MissionFigures, p: Params, out: Path) -> list[Path]:
    """Write the FILES into folder `out` (made if missing); returns their paths."""
    out.mkdir(parents=True, exist_ok=True)
    written = []
    fig, axes = _panels(f, "Achieved versus required rate per slot")
    for k, ax in axes.items():
        slots = np.arange(len(f.rates[k]))
        ax.plot(slots, f.rates[k] / 1e6, "o-", color=uav_color(k), ms=3, label="achieved")
        ax.axhline(p.rate_min_bps[k] / 1e6, ls="--", color="k", lw=1, label="R_min")
        ax.set(title=uav_name(k), xlabel="slot n", ylabel="rate [Mbit/s]")
    _finish(axes)
    written.append(_save(fig, out / FILES[0]))

    fig, axes = _panels(f, "Applied versus planned communication power")
    for k, ax in axes.items():
        ax.step(np.arange(f.num_slots), f.planned_power_w[k], "--", where="post", color="k",
                lw=1, label="planned")
        ax.step(np.arange(len(f.applied_w[k])), f.applied_w[k], where="post", color=uav_color(k),
                label="applied")
        ax.set(title=uav_name(k), xlabel="slot n", ylabel="P_com [W]")
    _finish(axes)
    written.append(_save(fig, out / FILES[1]))

    fig, axes = _panels(f, "Energy used versus budget")
    for k, ax in axes.items():
        ax.plot(np.arange(len(f.energy_j[k])), f.energy_j[k], color=uav_color(k), label="used")
        ax.axhline(f.budget_j[k], ls="--", color="k", lw=1, label="budget")
        ax.set(title=uav_name(k), xlabel="slot n", ylabel="energy [J]")
    _finish(axes)
    written.append(_save(fig, out / FILES[2]))

    fig, axes = _panels(f, "Position error along the track")
    for k, ax in axes.items():
        t = f.tracks[k]
        ax.plot(t.y, t.dx, color=uav_color(k), label="across-track x - x_k")
        ax.plot(t.y, t.dz, ":", color=uav_color(k), label="height z - z_k")
        ax.set(title=uav_name(k), xlabel="y (along-track) [m]", ylabel="error [m]")
    _finish(axes)
    written.append(_save(fig, out / FILES[3]))

    fig, ax = plt.subplots(figsize=(9, 4))
    for k in f.uavs:
        x, _, z = f.targets[k]
        t = f.tracks[k]
        # one legend row per UAV (ten of them fit): the flown dots take its colour unnamed
        ax.plot(x + t.dx, z + t.dz, ".", color=uav_color(k), ms=2, alpha=0.4,
                label="flown (each UAV's colour)" if k == f.uavs[0] else None)
        ax.plot([x], [z], "o", mfc="none", color=uav_color(k), ms=10,
                label=f"U{k} planned ({x:.1f}, {z:.1f}) m")
    gx, _, gz = p.ground_station
    ax.plot([p.x_t], [0], "k*", ms=12, label=f"target line x_t = {p.x_t:g} m")
    ax.plot([gx], [gz], "ks", ms=7, label="ground station")
    ax.set(xlabel="x (range / across-track) [m]", ylabel="z (altitude) [m]",
           title=f"Formation plane: sigma_h plan {f.sigma_h_plan_m:.4g} m, flown "
                 f"{f.sigma_h_flown_m:.4g} m")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    written.append(_save(fig, out / FILES[4]))
    return written


def _finish(axes: dict) -> None:
    for ax in axes.values():
        ax.grid(True, alpha=0.3)
    next(iter(axes.values())).legend(fontsize=7)
