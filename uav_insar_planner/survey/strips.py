"""Parallel strips whose radar swaths cover the area: one straight stripmap pass each.

Survey frame: `TrackFrame(psi, (0, 0, 0))` about the home, y along the bearing psi (from
north, clockwise), x to its right. The radar looks to the right of the direction of flight,
so its swath is a band `swath_m` (S_0) wide whose centre lies `look_offset_m` (z_0 tan
theta_0) right of the master's ground track. A strip flown along +y (direction +1) looks to
+x: its master line is at x = c - look_offset for a band centred at c; one flown along -y
(direction -1) looks to -x, so its master line sits on the other side, at c + look_offset.

Bands: centres spaced S_0 (1 - overlap) across track, as few as cover the area's x-extent
[x_min, x_max] of width W, laid symmetrically over it:

    count = 1 if W <= S_0 else ceil((W - S_0) / (S_0 (1 - overlap))) + 1

Along a band the strip images the y-extent of the area's intersection with the band. That
set is the projection onto y of the intersection's boundary, made of the area's edges clipped
to the band and the band's two edge lines clipped to the area (`band_intervals`). A concave
area can leave gaps along y: a gap up to S_0 long is flown over (imaging at most one swath
width outside the area), a longer one splits the band into separate strips. Every band meets
the area: the polygon is connected, so it spans every x in [x_min, x_max], and each band of
the fewest covers a part of that range of positive width; no band goes without a strip.

Order: boustrophedon, band after band across track, directions alternating, a band's strips
flown one after the other in its direction; of the four such orders (start at either side,
either direction first) the one whose first entry is nearest the home.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from uav_insar_planner.survey.area import Area
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.passes import TrackPass

XY = tuple[float, float]


@dataclass(frozen=True)
class Strip:
    """One strip in flight order `index`: band `band` (0 at the smallest survey x) centred
    at survey x = `centre_x_m`, flown as `track` (survey frame: x_m the master's line,
    y_start_m slot 0's line, the larger y for direction -1) on the survey bearing
    `bearing_rad`."""

    index: int
    band: int
    direction: int
    centre_x_m: float
    track: TrackPass
    bearing_rad: float
    swath_m: float
    look_offset_m: float

    @property
    def heading_rad(self) -> float:
        """The direction of flight from north, clockwise, in [0, 2 pi)."""
        return (self.bearing_rad + (0.0 if self.direction == 1 else math.pi)) % (2 * math.pi)

    @property
    def y_range(self) -> XY:
        """The imaged part's survey-frame y-extent (low, high)."""
        end = self.track.y_start_m + self.track.direction * self.track.length_m
        return min(self.track.y_start_m, end), max(self.track.y_start_m, end)

    def _ne(self, x: float, y: float) -> XY:
        n, e, _ = TrackFrame(self.bearing_rad).to_ned(x, y, 0.0)
        return n, e

    def master_line_ne(self) -> tuple[XY, XY]:
        """(north, east) of the master's ground track over the imaged part, in flight order."""
        return self._ne(*self.track.point(0.0)), self._ne(*self.track.point(self.track.length_m))

    def swath_ne(self) -> tuple[XY, XY, XY, XY]:
        """(north, east) corners of the imaged swath (band x imaged y-extent),
        counter-clockwise seen from above."""
        (lo, hi), half = self.y_range, 0.5 * self.swath_m
        left, right = self.centre_x_m - half, self.centre_x_m + half
        return (self._ne(left, lo), self._ne(right, lo), self._ne(right, hi),
                self._ne(left, hi))

    def frame(self, formation_x0: float = 0.0) -> TrackFrame:
        """The track frame the formation flies this strip in: bearing `heading_rad` (y along
        the flight, x to its right, where the radar looks) and origin (NED about the home,
        D = 0 at the home's height) such that the master, at x = `formation_x0` of that
        frame, flies this strip's master line and crosses slot 0's line at y = 0:
        origin = survey (x_m - direction formation_x0, y_start_m)."""
        ox = self.track.x_m - self.direction * formation_x0
        origin = TrackFrame(self.bearing_rad).to_ned(ox, self.track.y_start_m, 0.0)
        return TrackFrame(self.heading_rad, origin)


def survey_xy(points_ne: np.ndarray, bearing_rad: float) -> np.ndarray:
    """(k, 2) (north, east) points -> (k, 2) survey-frame (x, y) for bearing `bearing_rad`."""
    c, s = math.cos(bearing_rad), math.sin(bearing_rad)
    n, e = points_ne[:, 0], points_ne[:, 1]
    return np.column_stack((-n * s + e * c, n * c + e * s))


def band_centres(x_min: float, x_max: float, swath_m: float, overlap: float) -> np.ndarray:
    """The fewest band centres, S_0 (1 - overlap) apart, covering [x_min, x_max]
    symmetrically (module docstring)."""
    width, spacing = x_max - x_min, swath_m * (1.0 - overlap)
    count = 1 if width <= swath_m else math.ceil((width - swath_m) / spacing - 1e-9) + 1
    return 0.5 * (x_min + x_max) + (np.arange(count) - 0.5 * (count - 1)) * spacing


def band_intervals(xy: np.ndarray, x_left: float, x_right: float) -> list[XY]:
    """The y-intervals (sorted, disjoint) of the polygon `xy` (survey frame) cut by the band
    x_left <= x <= x_right: the projection of the cut's boundary (module docstring)."""
    x1, y1 = xy[:, 0], xy[:, 1]
    x2, y2 = np.roll(x1, -1), np.roll(y1, -1)
    dx = x2 - x1
    vertical = dx == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        t_a, t_b = (x_left - x1) / dx, (x_right - x1) / dx
    t0 = np.where(vertical, 0.0, np.maximum(np.minimum(t_a, t_b), 0.0))
    t1 = np.where(vertical, 1.0, np.minimum(np.maximum(t_a, t_b), 1.0))
    keep = np.where(vertical, (x1 >= x_left) & (x1 <= x_right), t0 <= t1)
    ya, yb = y1 + t0 * (y2 - y1), y1 + t1 * (y2 - y1)
    pieces = list(zip(np.minimum(ya, yb)[keep], np.maximum(ya, yb)[keep], strict=True))
    for x_line in (x_left, x_right):  # the band's edge lines inside the polygon
        crosses = (x1 <= x_line) != (x2 <= x_line)
        y = np.sort(y1[crosses] + (x_line - x1[crosses]) * (y2 - y1)[crosses] / dx[crosses])
        pieces += list(zip(y[0::2], y[1::2], strict=True))
    return merge_intervals(pieces, 0.0)


def merge_intervals(pieces: Sequence[XY], max_gap: float) -> list[XY]:
    """The union of `pieces` with every gap up to `max_gap` bridged, sorted."""
    merged: list[list[float]] = []
    for lo, hi in sorted(pieces):
        if merged and lo <= merged[-1][1] + max_gap:
            merged[-1][1] = max(merged[-1][1], float(hi))
        else:
            merged.append([float(lo), float(hi)])
    return [(lo, hi) for lo, hi in merged]


def _check(name: str, value: float, low: float, high: float, expected: str) -> None:
    if not (math.isfinite(value) and low <= value < high):
        raise ValueError(f"{name}: value {value!r} is not allowed; expected {expected}")


def _ordered(bands: list[tuple[int, float, list[XY]]], first_direction: int, bearing_rad: float,
             swath_m: float, look_offset_m: float, run_in_m: float) -> list[Strip]:
    strips: list[Strip] = []
    for k, (band, centre, segments) in enumerate(bands):
        direction = first_direction if k % 2 == 0 else -first_direction
        x_m = centre - direction * look_offset_m
        for lo, hi in segments[::direction]:
            start = lo if direction == 1 else hi
            track = TrackPass(x_m, start, hi - lo, direction, run_in_m)
            strips.append(Strip(len(strips), band, direction, centre, track, bearing_rad,
                                swath_m, look_offset_m))
    return strips


def layout_strips(area: Area, bearing_rad: float, swath_m: float, look_offset_m: float,
                  overlap: float = 0.0, run_in_m: float = 0.0) -> list[Strip]:
    """The strips covering `area` on the survey bearing `bearing_rad` (module docstring), in
    flight order; each strip's track carries `run_in_m`."""
    _check("swath_m", swath_m, 1e-9, math.inf, "a finite swath width > 0 m")
    _check("look_offset_m", look_offset_m, 0.0, math.inf, "a finite offset >= 0 m")
    _check("overlap", overlap, 0.0, 1.0, "a fraction in [0, 1)")
    _check("run_in_m", run_in_m, 0.0, math.inf, "a finite distance >= 0 m")
    _check("bearing_rad", bearing_rad, -math.inf, math.inf, "a finite angle")
    xy = survey_xy(area.ne, bearing_rad)
    half = 0.5 * swath_m
    bands = []
    for band, centre in enumerate(band_centres(xy[:, 0].min(), xy[:, 0].max(), swath_m,
                                               overlap)):
        cut = band_intervals(xy, centre - half, centre + half)
        segments = [(lo, hi) for lo, hi in merge_intervals(cut, swath_m) if hi > lo]
        if segments:
            bands.append((band, float(centre), segments))
    candidates = [_ordered(order, first, bearing_rad, swath_m, look_offset_m, run_in_m)
                  for order in (bands, bands[::-1]) for first in (1, -1)]
    return min(candidates, key=lambda s: math.hypot(*s[0].track.entry) if s else 0.0)


def strip_count(area: Area, bearing_rad: float, swath_m: float, overlap: float = 0.0) -> int:
    """How many bands cover `area` across the bearing (a cheap cost for `best_bearing`)."""
    x = survey_xy(area.ne, bearing_rad)[:, 0]
    return len(band_centres(float(x.min()), float(x.max()), swath_m, overlap))


def total_length_m(strips: Sequence[Strip]) -> float:
    """The strips' imaged length plus run-ins, transits left out [m]."""
    return sum(s.track.length_m + s.track.run_in_m for s in strips)


def best_bearing(area: Area, cost: Callable[[float], float], step_deg: float = 1.0) -> float:
    """The bearing in [0, pi) on a `step_deg` grid with the least `cost(bearing_rad)` (the
    first of equal ones). A bearing and its reverse lay the same bands, so [0, pi) is all."""
    _check("step_deg", step_deg, 1e-6, 180.0 + 1e-9, "a step in (0, 180] degrees")
    bearings = np.radians(np.arange(0.0, 180.0, step_deg))
    costs = [cost(float(b)) for b in bearings]
    return float(bearings[int(np.argmin(costs))])
