"""The coverage map of a flown survey (`uav-insar report BAG --survey survey.json`): two panels
over the area's grid cells, the planned and the flown sigma_h (survey/flown_coverage.py) on one
colour scale, unimaged cells hatched in red, the area's outline and the home; in metres east
and north of the home. Also the figures `coverage.json` holds.

Drawn with matplotlib's Agg back end (as figures.py), so it works without a screen.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from uav_insar_planner.survey.flown_coverage import FlownCoverage  # noqa: E402
from uav_insar_planner.survey.survey_file import SurveyFile  # noqa: E402

FILE = "coverage.png"
JSON_FILE = "coverage.json"
CM_BELOW_M = 1.0  # sigma_h under a metre is read in centimetres
GAP_FACE, GAP_HATCH = "#fde0dd", "tab:red"  # unimaged: light red, crossed in red


def _raster(c: FlownCoverage, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`values` on the cells' north-east grid (rows north, NaN off the area) and the grid's
    (north, east) centres of its first and last cells."""
    low = c.points_ne.min(axis=0)
    index = np.rint((c.points_ne - low) / c.cell_m).astype(int)
    image = np.full(tuple(index.max(axis=0) + 1), math.nan)
    image[index[:, 0], index[:, 1]] = values
    return image, np.array([low, low + index.max(axis=0) * c.cell_m])


def _panel(ax, c: FlownCoverage, values: np.ndarray, scale: float, limits: tuple[float, float]):
    """One panel: the cells coloured by sigma_h x `scale`, the unimaged ones hatched."""
    raster, (low, high) = _raster(c, values * scale)
    half = 0.5 * c.cell_m
    image = ax.imshow(raster, origin="lower", cmap="viridis", vmin=limits[0], vmax=limits[1],
                      extent=[low[1] - half, high[1] + half, low[0] - half, high[0] + half],
                      interpolation="nearest")
    gap, _ = _raster(c, (~np.isfinite(values)).astype(float))
    if np.nansum(gap) > 0:  # the gap's outline runs along the cells' edges (levels at 0.5)
        east = np.linspace(low[1], high[1], gap.shape[1])
        north = np.linspace(low[0], high[0], gap.shape[0])
        with plt.rc_context({"hatch.color": GAP_HATCH}):
            ax.contourf(east, north, np.nan_to_num(gap), levels=[0.5, 1.5], colors=[GAP_FACE],
                        hatches=["xxx"])
    return image


def plot_coverage(c: FlownCoverage, survey: SurveyFile, path: str | Path) -> None:
    """The two panels of `c` over `survey`'s area into `path` (PNG)."""
    both = np.concatenate([c.planned_m, c.flown_m])
    finite = both[np.isfinite(both)]
    top = float(finite.max()) if len(finite) else survey.sigma_h_m
    scale, unit = (100.0, "cm") if top < CM_BELOW_M else (1.0, "m")
    low = float(finite.min()) if len(finite) else top
    pad = max(1e-3 * top, 1e-9) if math.isclose(low, top) else 0.0
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5), sharex=True, sharey=True,
                             layout="constrained")
    ring = np.array(survey.area.ring_ne + (survey.area.ring_ne[0],))
    image = None
    for ax, values, title in (
            (axes[0], c.planned_m, f"planned: {c.planned_fraction:.1%} of the area imaged"),
            (axes[1], c.flown_m, f"flown: {c.flown_fraction:.1%} imaged with usable data")):
        image = _panel(ax, c, values, scale, ((low - pad) * scale, (top + pad) * scale))
        ax.plot(ring[:, 1], ring[:, 0], "k-", lw=1.2, label="area")
        ax.plot(0.0, 0.0, "k^", ms=9, label="home")
        gaps = int(np.sum(~np.isfinite(values)))
        handles = ax.get_legend_handles_labels()[0] + [Patch(
            facecolor=GAP_FACE, edgecolor=GAP_HATCH, hatch="xxx",
            label=f"unimaged: {gaps} cells of {c.cell_m:g} m")]
        ax.set(title=title, xlabel="east of home [m]", aspect="equal")
        ax.legend(handles=handles, loc="best", fontsize=8)
    axes[0].set_ylabel("north of home [m]")
    fig.colorbar(image, ax=list(axes), shrink=0.85,
                 label=f"sigma_h [{unit}] (flown: the best slot over each cell)")
    fig.suptitle(f"{len(survey.strips)} strips; plan sigma_h {survey.sigma_h_m * scale:.3g} "
                 f"{unit}", fontsize=10)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def coverage_summary(c: FlownCoverage, survey: SurveyFile,
                     flown: Mapping[int, Sequence[tuple[int, float]]]) -> dict:
    """What `coverage.json` holds: the covered fractions, the grid, the plan's sigma_h, and
    per strip flown its slots flown and usable (finite sigma_h) of its slot count."""
    finite = c.flown_m[np.isfinite(c.flown_m)]
    return {
        "planned_fraction": c.planned_fraction, "flown_fraction": c.flown_fraction,
        "cell_m": c.cell_m, "cells": len(c.points_ne), "sigma_h_plan_m": survey.sigma_h_m,
        "sigma_h_flown_best_m": float(finite.min()) if len(finite) else None,
        "sigma_h_flown_worst_m": float(finite.max()) if len(finite) else None,
        "strips": {str(i): {"num_slots": survey.num_slots[i], "slots_flown": len(slots),
                            "slots_usable": sum(math.isfinite(s) for _, s in slots)}
                   for i, slots in sorted(flown.items())},
    }
