"""What a flown survey imaged, and how well: the planned and the flown sigma_h on the area's
grid of ground cells.

Cells: the centres p of the grid's cells inside the area (survey/coverage.py `grid_points`,
`cell_m` square; by default `cell_size_m`, the planner's own check's). For strip i (imaged
length L_i, N_i slots, the direction of flight u_i, r_i to its right, p0_i the master on slot
0's line, o the look offset, S the swath; coverage.py's geometry)

    a_i(p) = (p - p0_i) . u_i,   c_i(p) = (p - p0_i) . r_i,
    strip i images p   iff   0 <= a_i(p) <= L_i   and   |c_i(p) - o| <= S / 2,

and of that ground its slot n images the part with n L_i / N_i <= a_i(p) < (n + 1) L_i / N_i
(the last slot also a_i = L_i; the edges' TOLERANCE_M of coverage.py belongs to the nearest
slot): slot_i(p) = min(N_i - 1, max(0, floor(a_i(p) N_i / L_i))).

`flown[i]` lists strip i's slots as flown, (n, sigma_{i,n}): the fused height error of the
formation as flown in that slot [m], NaN when its data is unusable (a rate missed, a UAV
missing). A slot flown twice (a strip flown again) is listed twice. Then

    planned(p) = sigma_plan                         if some strip images p, else NaN,
    flown(p)   = min { sigma_{i,n} : (n, sigma_{i,n}) in flown[i], sigma_{i,n} finite,
                       strip i images p, slot_i(p) = n }          (NaN: the set is empty),

the best (least) height error any usable flight of p gave. The covered fractions are the
shares of cells with a finite value, planned and flown. Every slot flown and usable gives
flown(p) finite exactly where planned(p) is.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from uav_insar_planner.survey.coverage import (
    cell_size_m,
    grid_points,
    strip_coordinates,
    strip_images,
)
from uav_insar_planner.survey.survey_file import SurveyFile


@dataclass(frozen=True)
class FlownCoverage:
    """The cells' (north, east) centres (k, 2) [m], the cell size [m], and per cell the
    planned and the flown sigma_h [m] (NaN: unimaged) (module docstring)."""

    points_ne: np.ndarray
    cell_m: float
    planned_m: np.ndarray
    flown_m: np.ndarray

    @property
    def planned_fraction(self) -> float:
        """The share of the area's cells some strip's swath images."""
        return float(np.mean(np.isfinite(self.planned_m))) if len(self.planned_m) else 0.0

    @property
    def flown_fraction(self) -> float:
        """The share of the area's cells some usable flown slot imaged."""
        return float(np.mean(np.isfinite(self.flown_m))) if len(self.flown_m) else 0.0


def slot_of(along: np.ndarray, length_m: float, num_slots: int) -> np.ndarray:
    """slot_i(p) of the module docstring for the points at `along` a_i(p) [m]."""
    raw = np.floor(np.asarray(along, dtype=float) * num_slots / length_m)
    return np.clip(raw, 0, num_slots - 1).astype(int)


def _checked(survey: SurveyFile, flown: Mapping[int, Sequence[tuple[int, float]]]
             ) -> dict[int, list[tuple[int, float]]]:
    """`flown` with every strip and slot of the survey and every sigma NaN or >= 0 (one-line
    ValueError naming the first that is not)."""
    count = len(survey.strips)
    out = {}
    for i, slots in flown.items():
        if not (isinstance(i, (int, np.integer)) and 0 <= i < count):
            raise ValueError(f"flown strip {i!r}: not allowed; expected a strip of the survey "
                             f"(0 to {count - 1})")
        checked = []
        for n, sigma in slots:
            if not (isinstance(n, (int, np.integer)) and 0 <= n < survey.num_slots[i]):
                raise ValueError(f"flown strip {i} slot {n!r}: not allowed; expected a slot "
                                 f"of that strip (0 to {survey.num_slots[i] - 1})")
            if not (math.isnan(sigma) or (math.isfinite(sigma) and sigma >= 0.0)):
                raise ValueError(f"flown strip {i} slot {n} sigma_h {sigma!r}: not allowed; "
                                 "expected a height error >= 0 m, or NaN (unusable)")
            checked.append((int(n), float(sigma)))
        out[int(i)] = checked
    return out


def flown_coverage(survey: SurveyFile, sigma_h_plan_m: float,
                   flown: Mapping[int, Sequence[tuple[int, float]]],
                   cell_m: float | None = None) -> FlownCoverage:
    """The planned and flown sigma_h on the area's cells (module docstring); `cell_m` None:
    coverage.cell_size_m. ValueError (one line) for a strip or slot not in `survey`."""
    flown = _checked(survey, flown)
    cell = cell_size_m(survey.area) if cell_m is None else cell_m
    points = grid_points(survey.area, cell)
    if not len(points):  # an area smaller than a cell: its vertices stand in
        points = survey.area.ne
    planned = np.full(len(points), math.nan)
    best = np.full(len(points), math.inf)
    for i, strip in enumerate(survey.strips):
        along, across = strip_coordinates(points, strip)
        inside = strip_images(along, across, strip, survey.swath_m)
        planned[inside] = sigma_h_plan_m
        usable = [(n, s) for n, s in flown.get(i, []) if math.isfinite(s)]
        if not usable or not inside.any():
            continue
        where = np.flatnonzero(inside)
        slot = slot_of(along[where], strip.track.length_m, survey.num_slots[i])
        for n, sigma in usable:
            hit = where[slot == n]
            best[hit] = np.minimum(best[hit], sigma)
    flown_m = np.where(np.isfinite(best), best, math.nan)
    return FlownCoverage(points, float(cell), planned, flown_m)
