"""The area to survey: one polygon (GeoJSON or KML) projected to metres about the home.

Input: a GeoJSON text (RFC 7946, positions [lon, lat(, alt)] in degrees) holding one Polygon
(bare, in a Feature, in a FeatureCollection whose other features are no polygons, or a
MultiPolygon of one polygon), or a KML text with one <Polygon> (coordinates "lon,lat[,alt]").
Holes are refused: a strip over a hole images it anyway, so a hole would only be a promise
the layout cannot keep. The closing position (RFC 7946 repeats the first) is optional and
dropped, as are repeated consecutive positions.

Local frame: (north, east) metres about the home with `mission_file.geodesy.latlon_to_ned`,
the same map the mission files go back through (`ned_to_latlon`, its exact inverse), so a
strip laid in these metres lands where it was laid relative to the area's own vertices. The
map's absolute error, below d^2 (1 + |tan phi0|) / a at a distance d from the home, is
therefore not what limits a survey; its scale error is, which stretches a swath's width:
the derivative, 2 d (1 + |tan phi0|) / a. MAX_DISTANCE_M = 10 km keeps that below 0.63 % at
|phi0| <= 45 deg (0.6 m of a 100 m swath, under any overlap worth flying) and the absolute
error below 31 m (17 m measured). Farther areas take a home of their own.

The ring is kept counter-clockwise seen from above (the shoelace sum over (east, north) is
positive), in the same order for `ring_lonlat` and `ring_ne`, without the closing point.
"""
from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Any

import numpy as np

from uav_insar_planner.mission_file.geodesy import POLE_MARGIN_DEG, latlon_to_ned
from uav_insar_planner.mission_file.qgc_plan import Home

MAX_DISTANCE_M = 10_000.0  # from the home to any vertex (module docstring)
MIN_AREA_M2 = 1.0  # below it the "area" is a line or a point
SHORT_CHARS = 40  # values quoted in messages are cut to this length


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= SHORT_CHARS else text[:SHORT_CHARS - 3] + "..."


def _refuse(field: str, value: Any, expected: str) -> ValueError:
    return ValueError(f"{field}: value {_short(value)} is not allowed; expected {expected}")


@dataclass(frozen=True)
class Area:
    """The polygon to survey (module docstring): vertices as (lon, lat) degrees and as
    (north, east) metres about `home`, counter-clockwise, without the closing point."""

    home: Home
    ring_lonlat: tuple[tuple[float, float], ...]
    ring_ne: tuple[tuple[float, float], ...]

    @property
    def ne(self) -> np.ndarray:
        """The ring as an (n, 2) array of (north, east) metres."""
        return np.asarray(self.ring_ne, dtype=float)

    @property
    def area_m2(self) -> float:
        return shoelace_m2(self.ne)

    def contains(self, points_ne: np.ndarray) -> np.ndarray:
        """Which of the (k, 2) (north, east) points lie inside (even-odd rule; a point on
        the boundary may fall either way)."""
        return inside_polygon(self.ne, np.asarray(points_ne, dtype=float).reshape(-1, 2))


def shoelace_m2(ring_ne: np.ndarray) -> float:
    """Signed area of a (north, east) ring: > 0 counter-clockwise seen from above."""
    n, e = ring_ne[:, 0], ring_ne[:, 1]
    return 0.5 * float(np.sum(e * np.roll(n, -1) - np.roll(e, -1) * n))


def inside_polygon(ring: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Even-odd ray casting of (k, 2) points against a ring, both in the same 2-D axes."""
    inside = np.zeros(len(points), dtype=bool)
    u, v = points[:, 0], points[:, 1]
    for (ui, vi), (uj, vj) in zip(ring, np.roll(ring, -1, axis=0), strict=True):
        crosses = (ui > u) != (uj > u)
        if not crosses.any():
            continue
        v_cross = vi + (u - ui) * (vj - vi) / np.where(crosses, uj - ui, 1.0)
        inside ^= crosses & (v < v_cross)
    return inside


def self_intersection(ring: np.ndarray) -> tuple[int, int] | None:
    """The first pair of edges (i, j) that touch or cross other than at their shared vertex
    (edge i runs from vertex i to vertex i + 1), or None for a simple ring."""
    a, b = ring, np.roll(ring, -1, axis=0)
    count = len(ring)
    for i in range(count):  # adjacent edges: only a fold back onto itself meets twice
        d1, d2 = b[i] - a[i], b[(i + 1) % count] - a[(i + 1) % count]
        if abs(d1[0] * d2[1] - d1[1] * d2[0]) <= 1e-12 * (d1 @ d1 + d2 @ d2) and d1 @ d2 < 0:
            return i, (i + 1) % count

    def orient(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
        return (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - \
               (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0])

    for i in range(count - 2):
        j = np.arange(i + 2, count if i > 0 else count - 1)
        if not len(j):
            continue
        p, q, r, s = a[i], b[i], a[j], b[j]
        hit = (orient(r, s, p) * orient(r, s, q) <= 0) & (orient(p, q, r) * orient(p, q, s) <= 0)
        for k in (0, 1):  # bounding boxes overlap (decides the collinear case)
            hit &= (np.minimum(r[:, k], s[:, k]) <= max(p[k], q[k])) & \
                   (np.maximum(r[:, k], s[:, k]) >= min(p[k], q[k]))
        if hit.any():
            return i, int(j[np.argmax(hit)])
    return None


def _geojson_rings(doc: Any) -> list:
    """The polygon's rings (positions as given) from a GeoJSON object."""
    kind = doc.get("type") if isinstance(doc, dict) else None
    if kind == "FeatureCollection":
        features = doc.get("features")
        if not isinstance(features, list):
            raise _refuse("area.features", features, "a list of GeoJSON Features")
        polygons = [f.get("geometry") for f in features if isinstance(f, dict)
                    and isinstance(f.get("geometry"), dict)
                    and f["geometry"].get("type") in ("Polygon", "MultiPolygon")]
        if len(polygons) != 1:
            raise _refuse("area.features", f"{len(polygons)} polygons",
                          "exactly one Feature holding a Polygon")
        return _geojson_rings(polygons[0])
    if kind == "Feature":
        return _geojson_rings(doc.get("geometry"))
    if kind not in ("Polygon", "MultiPolygon"):
        raise _refuse("area.type", kind if kind is not None else doc,
                      "a GeoJSON Polygon, MultiPolygon of one polygon, Feature or "
                      "FeatureCollection holding one")
    coordinates = doc.get("coordinates")
    if kind == "MultiPolygon":
        if not isinstance(coordinates, list) or len(coordinates) != 1:
            raise _refuse("area.coordinates", coordinates,
                          "a MultiPolygon of exactly one polygon")
        coordinates = coordinates[0]
    if not isinstance(coordinates, list) or not coordinates:
        raise _refuse("area.coordinates", coordinates, "a list of linear rings")
    return coordinates


def _kml_rings(text: str) -> list:
    """The polygon's rings as [[lon, lat], ...] lists from a KML text."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise _refuse("area", text, f"GeoJSON or KML (XML: {exc})") from None
    polygons = [e for e in root.iter() if e.tag.rsplit("}", 1)[-1] == "Polygon"]
    if len(polygons) != 1:
        raise _refuse("area.Polygon", f"{len(polygons)} polygons", "exactly one KML <Polygon>")
    rings = []
    for boundary in ("outerBoundaryIs", "innerBoundaryIs"):
        for element in polygons[0].iter():
            if element.tag.rsplit("}", 1)[-1] != boundary:
                continue
            found = [e.text or "" for e in element.iter()
                     if e.tag.rsplit("}", 1)[-1] == "coordinates"]
            tuples = found[0].split() if found else []
            try:
                rings.append([[float(v) for v in t.split(",")] for t in tuples])
            except ValueError:
                raise _refuse("area.coordinates", found[0].strip(),
                              "KML tuples lon,lat[,alt] separated by spaces") from None
    if not rings:
        raise _refuse("area.Polygon", "no outerBoundaryIs", "a KML <Polygon> with an "
                      "<outerBoundaryIs><LinearRing><coordinates>")
    return rings


def _outer_ring(rings: list) -> list[tuple[float, float]]:
    """The one ring's (lon, lat) positions, checked, without repeats or the closing point."""
    if len(rings) > 1:
        raise _refuse("area.coordinates", f"{len(rings) - 1} holes",
                      "a polygon without holes (one ring)")
    ring = rings[0]
    if not isinstance(ring, list):
        raise _refuse("area.coordinates[0]", ring, "a list of [lon, lat] positions")
    positions: list[tuple[float, float]] = []
    for i, position in enumerate(ring):
        field = f"area.coordinates[0][{i}]"
        if not (isinstance(position, list) and len(position) >= 2 and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in position[:2])):
            raise _refuse(field, position, "a position [lon, lat] of finite numbers")
        lon, lat = float(position[0]), float(position[1])
        if not (-180.0 <= lon <= 180.0 and -90.0 <= lat <= 90.0):
            raise _refuse(field, position, "[lon, lat] with lon in [-180, 180] and lat in "
                          "[-90, 90] degrees (GeoJSON puts the longitude first)")
        if not positions or positions[-1] != (lon, lat):
            positions.append((lon, lat))
    if len(positions) > 1 and positions[0] == positions[-1]:
        positions.pop()
    if len(positions) < 3:
        raise _refuse("area.coordinates[0]", ring, "at least 3 distinct vertices")
    return positions


def read_area(text: str, home: Home) -> Area:
    """The area in `text` (GeoJSON or KML, module docstring) about `home`; ValueError with a
    one-line message naming the field otherwise."""
    if not (abs(home.lat_deg) <= 90.0 - POLE_MARGIN_DEG and -180.0 <= home.lon_deg <= 180.0):
        raise _refuse("home", (home.lat_deg, home.lon_deg), f"lat within "
                      f"{90.0 - POLE_MARGIN_DEG:g} deg of the equator and lon in [-180, 180]")
    if text.lstrip().startswith("<"):
        rings = _kml_rings(text)
    else:
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise _refuse("area", text, f"GeoJSON or KML (JSON: {exc.msg} at line "
                          f"{exc.lineno} column {exc.colno})") from None
        rings = _geojson_rings(doc)
    lonlat = _outer_ring(rings)
    ne = np.array([latlon_to_ned(home.lat_deg, home.lon_deg, lat, lon) for lon, lat in lonlat])
    distance = np.hypot(ne[:, 0], ne[:, 1])
    if distance.max() > MAX_DISTANCE_M:
        i = int(np.argmax(distance))
        swapped = math.hypot(*latlon_to_ned(home.lat_deg, home.lon_deg, *lonlat[i]))
        hint = "; GeoJSON puts the longitude first" if swapped <= MAX_DISTANCE_M else ""
        raise _refuse(f"area.coordinates[0][{i}]", list(lonlat[i]), f"a vertex within "
                      f"{MAX_DISTANCE_M:.0f} m of the home (it is {distance[i]:.0f} m away"
                      f"{hint})")
    spread = np.linalg.svd(ne - ne.mean(axis=0), compute_uv=False)[1] / math.sqrt(len(ne))
    crossing = self_intersection(ne) if spread > 1e-3 else None  # a line folds onto itself
    if crossing is not None:
        i, j = crossing
        raise _refuse("area.coordinates[0]", [list(p) for p in lonlat], "a simple ring; this "
                      f"one is self-intersecting: its edges from vertex {i} and from vertex {j} "
                      "meet")
    signed = shoelace_m2(ne)
    if abs(signed) < MIN_AREA_M2:
        raise _refuse("area.coordinates[0]", [list(p) for p in lonlat],
                      f"a polygon of at least {MIN_AREA_M2:g} m^2 (it has {abs(signed):.3g})")
    if signed < 0:
        lonlat, ne = lonlat[::-1], ne[::-1]
    return Area(home, tuple((float(a), float(b)) for a, b in lonlat),
                tuple((float(n), float(e)) for n, e in ne))
