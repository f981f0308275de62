"""How much of the area the strips image: brute force on a grid, independent of the layout.

The grid's cells (`cell_m` square, aligned with north and east about the home) whose centres
lie inside the area are the sample. A strip images the ground band `swath_m` wide centred
`look_offset_m` to the right of its master's ground track (the radar's side) along the
imaged part of its track: for a point p, with u the unit vector of the flight and r the one
to its right (both in (north, east)), and p0 the master at slot 0's line,

    0 <= (p - p0) . u <= length_m   and   |(p - p0) . r - look_offset_m| <= swath_m / 2.

This is built from each strip's track and heading alone, not from its band's centre, so it
checks the layout's sides and offsets as well as its extents.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from uav_insar_planner.survey.area import Area
from uav_insar_planner.survey.strips import Strip

TOLERANCE_M = 1e-6  # a point on a swath's edge counts as imaged (adjacent swaths share edges)
CELL_M = 2.0  # the grid's cell; coarser on big areas, so that at most CELLS_MAX cells are tested
CELLS_MAX = 10_000


def cell_size_m(area: Area) -> float:
    """The grid's cell for `area`: CELL_M, or coarser so that it holds about CELLS_MAX."""
    return max(CELL_M, math.sqrt(area.area_m2 / CELLS_MAX))


def grid_points(area: Area, cell_m: float) -> np.ndarray:
    """(k, 2) (north, east) centres of the grid's cells inside the area."""
    if not (math.isfinite(cell_m) and cell_m > 0.0):
        raise ValueError(f"cell_m: value {cell_m!r} is not allowed; expected a finite cell "
                         "size > 0 m")
    ne = area.ne
    low, high = ne.min(axis=0), ne.max(axis=0)
    n = np.arange(low[0] + 0.5 * cell_m, high[0], cell_m)
    e = np.arange(low[1] + 0.5 * cell_m, high[1], cell_m)
    points = np.stack(np.meshgrid(n, e, indexing="ij"), axis=-1).reshape(-1, 2)
    return points[area.contains(points)]


def strip_coordinates(points_ne: np.ndarray, strip: Strip) -> tuple[np.ndarray, np.ndarray]:
    """(along, across) of the (k, 2) (north, east) points about `strip`: (p - p0) . u and
    (p - p0) . r of the module docstring [m]."""
    heading = strip.heading_rad
    u = np.array([math.cos(heading), math.sin(heading)])
    r = np.array([-u[1], u[0]])  # right of the flight: heading north -> east
    points = np.asarray(points_ne, dtype=float).reshape(-1, 2)
    rel = points - np.asarray(strip.master_line_ne()[0])
    return rel @ u, rel @ r


def strip_images(along: np.ndarray, across: np.ndarray, strip: Strip, swath_m: float
                 ) -> np.ndarray:
    """Which points, at `strip_coordinates` (along, across), `strip` images (module
    docstring; TOLERANCE_M on every edge)."""
    return ((along >= -TOLERANCE_M) & (along <= strip.track.length_m + TOLERANCE_M)
            & (np.abs(across - strip.look_offset_m) <= 0.5 * swath_m + TOLERANCE_M))


def imaged(points_ne: np.ndarray, strips: Sequence[Strip], swath_m: float) -> np.ndarray:
    """Which of the (k, 2) (north, east) points at least one strip images (module
    docstring)."""
    hit = np.zeros(len(points_ne), dtype=bool)
    for strip in strips:
        left = np.flatnonzero(~hit)  # (a point one strip images needs no other)
        along, across = strip_coordinates(points_ne[left], strip)
        hit[left] = strip_images(along, across, strip, swath_m)
    return hit


def covered_fraction(area: Area, strips: Sequence[Strip], swath_m: float,
                     cell_m: float) -> float:
    """The fraction of the area's grid cells (by their centres) some strip images."""
    points = grid_points(area, cell_m)
    if not len(points):  # an area smaller than a cell: its vertices stand in
        points = area.ne
    return float(np.mean(imaged(points, strips, swath_m)))


def uncovered(area: Area, strips: Sequence[Strip], swath_m: float, cell_m: float
              ) -> np.ndarray:
    """(k, 2) (north, east) centres of the area's grid cells no strip images (for maps)."""
    points = grid_points(area, cell_m)
    return points[~imaged(points, strips, swath_m)]
