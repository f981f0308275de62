"""Survey geometry (uav_insar_planner/survey/): areas of several shapes, their strips, and the
brute-force coverage check; the reader's one-line refusals."""
from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from uav_insar_planner.mission_file.geodesy import ned_to_latlon
from uav_insar_planner.mission_file.qgc_plan import Home
from uav_insar_planner.survey.area import read_area
from uav_insar_planner.survey.coverage import covered_fraction, uncovered
from uav_insar_planner.survey.strips import (
    best_bearing,
    layout_strips,
    strip_count,
    total_length_m,
)
from uav_insar_planner.track.passes import TrackPass

HOME = Home(47.5, 8.5, 420.0)
S0, LOOK, OVERLAP, RUN_IN = 100.0, 80.0, 0.1, 25.0


def lonlat(ne):
    return [list(ned_to_latlon(HOME.lat_deg, HOME.lon_deg, n, e))[::-1] for n, e in ne]


def geojson(ne, close=True):
    ring = lonlat(ne)
    return json.dumps({"type": "Polygon", "coordinates": [ring + ring[:1] if close else ring]})


def area_of(ne):
    return read_area(geojson(ne), HOME)


def rectangle(along_m, across_m, bearing_deg=0.0, centre=(300.0, -200.0)):
    """A rectangle `along_m` long on the bearing `bearing_deg`, `across_m` wide, in NE."""
    b = math.radians(bearing_deg)
    u, r = np.array([math.cos(b), math.sin(b)]), np.array([-math.sin(b), math.cos(b)])
    corners = [(-1, -1), (-1, 1), (1, 1), (1, -1)]
    return [tuple(np.asarray(centre) + 0.5 * (a * along_m * u + c * across_m * r))
            for a, c in corners]


def u_shape(gap_m, notch_m=350.0):
    """600 m square about the origin's NE quadrant, notch open to the east: `gap_m` long
    along north, `notch_m` deep."""
    lo, hi = 300.0 - 0.5 * gap_m, 300.0 + 0.5 * gap_m
    return [(0, 0), (0, 600), (lo, 600), (lo, 600 - notch_m), (hi, 600 - notch_m),
            (hi, 600), (600, 600), (600, 0)]


SHAPES = {
    "rectangle": rectangle(600, 400),
    "rotated rectangle": rectangle(900, 350, 33.0),
    "triangle": [(0, 0), (700, 150), (100, 500)],
    "U, notch wider than a swath": u_shape(200.0),
    "U, notch narrower than a swath": u_shape(60.0),
    "L": [(0, 0), (800, 0), (800, 150), (150, 150), (150, 500), (0, 500)],
    "thin": rectangle(800, 40, 70.0),
    "tiny": rectangle(5, 4, 10.0),
    "comb": [(0, 0), (0, 700), (500, 700), (500, 560), (120, 560), (120, 420), (500, 420),
             (500, 280), (120, 280), (120, 140), (500, 140), (500, 0)],
}


def check_swaths(strips):
    """Each swath S0 wide, centred LOOK right of its master line (cross products in NE)."""
    for s in strips:
        start, end = (np.array(p) for p in s.master_line_ne())
        h = np.array([math.cos(s.heading_rad), math.sin(s.heading_rad)])  # (n, e)
        if s.track.length_m > 1.0:
            assert np.allclose((end - start) / np.linalg.norm(end - start), h)
        corners = np.array(s.swath_ne())
        assert np.linalg.norm(corners[1] - corners[0]) == pytest.approx(S0, rel=1e-9)
        assert np.linalg.norm(corners[2] - corners[3]) == pytest.approx(S0, rel=1e-9)
        assert abs((corners[1] - corners[0]) @ h) < 1e-6  # the width is across the flight
        v = corners.mean(axis=0) - start
        cross = h[1] * v[0] - h[0] * v[1]  # z of (e, n) heading x (e, n) offset: < 0 = right
        assert cross == pytest.approx(-LOOK, abs=1e-6)
        assert np.linalg.norm(corners[2] - corners[1]) == pytest.approx(s.track.length_m,
                                                                         abs=1e-6)


@pytest.mark.parametrize("bearing_deg", [0.0, 30.0, 90.0, 137.0])
@pytest.mark.parametrize("shape", sorted(SHAPES))
def test_every_shape_is_covered_by_right_looking_swaths(shape, bearing_deg):
    area = area_of(SHAPES[shape])
    strips = layout_strips(area, math.radians(bearing_deg), S0, LOOK, OVERLAP, RUN_IN)
    assert strips and [s.index for s in strips] == list(range(len(strips)))
    cell = 1.0 if shape == "tiny" else 5.0
    assert covered_fraction(area, strips, S0, cell) >= 0.995, shape
    check_swaths(strips)
    bands = sorted({s.band for s in strips})
    assert bands == list(range(strip_count(area, math.radians(bearing_deg), S0, OVERLAP)))
    for s in strips:
        assert s.track.run_in_m == RUN_IN
        assert s.track.x_m == pytest.approx(s.centre_x_m - s.direction * LOOK)


def test_a_swath_on_the_wrong_side_is_caught_by_the_coverage_check():
    """The check reads only the tracks: flipping the look side loses most of the area."""
    area = area_of(SHAPES["rectangle"])
    strips = layout_strips(area, 0.0, S0, LOOK, OVERLAP)
    assert covered_fraction(area, strips, S0, 5.0) == 1.0
    assert covered_fraction(area, strips, 0.5 * S0, 5.0) < 0.7
    assert len(uncovered(area, strips, 0.5 * S0, 5.0)) > 100
    assert len(uncovered(area, strips, S0, 5.0)) == 0
    # the same tracks seen from the other side (direction flipped, line unchanged)
    flipped = [replace(s, direction=-s.direction, track=TrackPass(
        s.track.x_m, s.track.y_start_m + s.direction * s.track.length_m, s.track.length_m,
        -s.direction)) for s in strips]
    assert covered_fraction(area, flipped, S0, 5.0) < 0.8


@pytest.mark.parametrize("overlap", [0.0, 0.1, 0.3])
@pytest.mark.parametrize("width", [30.0, 100.0, 150.0, 460.0, 500.0, 1234.0])
def test_strip_count_of_a_rectangle(width, overlap):
    area = area_of(rectangle(700, width, 20.0))
    strips = layout_strips(area, math.radians(20.0), S0, LOOK, overlap)
    expected = max(1, math.ceil((width - S0) / (S0 * (1 - overlap)) - 1e-9) + 1)
    assert len(strips) == expected
    assert all(s.track.length_m == pytest.approx(700.0, abs=1e-6) for s in strips)
    centres = sorted(s.centre_x_m for s in strips)
    assert np.allclose(np.diff(centres), S0 * (1 - overlap))
    assert np.mean(centres) == pytest.approx(np.mean([min(centres), max(centres)]))
    # laid symmetrically: the same margin beyond the area on both sides
    margin = 0.5 * ((len(strips) - 1) * S0 * (1 - overlap) + S0 - width)
    assert margin >= -1e-9
    assert covered_fraction(area, strips, S0, 5.0) == 1.0


def test_boustrophedon_order():
    area = area_of(rectangle(600, 900, 0.0))
    strips = layout_strips(area, 0.0, S0, LOOK, OVERLAP, RUN_IN)
    bands = [s.band for s in strips]
    assert bands in (sorted(bands), sorted(bands, reverse=True))
    assert all(a.direction == -b.direction for a, b in zip(strips, strips[1:], strict=False))
    for a, b in zip(strips, strips[1:], strict=False):  # each next entry is at this one's end
        end_y = a.track.y_start_m + a.direction * a.track.length_m
        assert abs(b.track.entry[1] - end_y) <= RUN_IN + 1e-6


@pytest.mark.parametrize("bearing_deg", [35.0, 125.0])
def test_the_best_bearing_of_a_long_thin_rectangle_is_along_it(bearing_deg):
    area = area_of(rectangle(2000, 150, bearing_deg))

    def cost(b):
        strips = layout_strips(area, b, S0, LOOK, OVERLAP, RUN_IN)
        return 1e4 * len(strips) + total_length_m(strips)

    assert math.degrees(best_bearing(area, cost)) == pytest.approx(bearing_deg, abs=0.5)
    count = best_bearing(area, lambda b: strip_count(area, b, S0, OVERLAP), step_deg=5.0)
    assert abs(math.degrees(count) - bearing_deg) <= 5.0


@pytest.mark.parametrize("gap", [60.0, 99.0, 101.0, 200.0])
def test_a_band_splits_only_over_a_gap_longer_than_a_swath(gap):
    area = area_of(u_shape(gap))
    strips = layout_strips(area, 0.0, S0, LOOK, OVERLAP)
    per_band = {}
    for s in strips:
        per_band.setdefault(s.band, []).append(s)
    split = [b for b, ss in per_band.items() if len(ss) > 1]
    if gap < S0:
        assert not split
    else:
        assert split and all(len(ss) == 2 for ss in per_band.values() if len(ss) > 1)
        for b in split:  # the two parts sit on either side of the notch
            (lo0, hi0), (lo1, hi1) = sorted(s.y_range for s in per_band[b])
            assert lo1 - hi0 == pytest.approx(gap, abs=1e-6)
            assert per_band[b][0].centre_x_m - 0.5 * S0 >= 250.0 - 1e-6
    assert covered_fraction(area, strips, S0, 5.0) >= 0.995


def test_a_thin_and_a_tiny_area_take_one_strip_over_their_middle():
    for ne in (rectangle(800, 40, 70.0), rectangle(5, 4, 10.0)):
        area = area_of(ne)
        (strip,) = layout_strips(area, math.radians(70.0), S0, LOOK, OVERLAP)
        middle = np.mean(np.array(strip.swath_ne()), axis=0)
        assert np.allclose(middle, np.mean(area.ne, axis=0), atol=1e-6)


@pytest.mark.parametrize("direction_first", [0, 1])
def test_the_formation_frame_flies_the_master_line(direction_first):
    area = area_of(rectangle(600, 400))
    strip = layout_strips(area, 0.4, S0, LOOK, OVERLAP, RUN_IN)[direction_first]
    x0 = -12.5
    frame = strip.frame(x0)
    start, end = strip.master_line_ne()
    assert np.allclose(frame.to_ned(x0, 0.0, 30.0)[:2], start)
    assert np.allclose(frame.to_ned(x0, strip.track.length_m, 30.0)[:2], end)
    assert frame.to_ned(x0, 0.0, 30.0)[2] == pytest.approx(-30.0)
    corners = np.array(strip.swath_ne())  # the radar looks to the frame's +x
    centre = frame.to_ned(x0 + LOOK, 0.5 * strip.track.length_m, 0.0)[:2]
    assert np.allclose(centre, corners.mean(axis=0))


def test_area_reading_variants_agree():
    ne = SHAPES["L"]  # clockwise seen from above: north, then east, then back
    base = area_of(ne)
    assert base.area_m2 == pytest.approx(800 * 150 + 150 * 350, rel=1e-9)
    assert np.allclose(base.ne, np.array(ne[::-1], dtype=float), atol=1e-6)  # turned CCW
    ccw = read_area(geojson(ne[::-1], close=False), HOME)  # kept as given, no closing point
    assert np.allclose(ccw.ne, base.ne, atol=1e-9)
    assert ccw.ring_lonlat == base.ring_lonlat
    polygon = json.loads(geojson(ne))
    feature = {"type": "Feature", "properties": {}, "geometry": polygon}
    marker = {"type": "Feature", "geometry": {"type": "Point", "coordinates": [8.5, 47.5]}}
    multi = {"type": "MultiPolygon", "coordinates": [polygon["coordinates"]]}
    for doc in (feature, {"type": "FeatureCollection", "features": [marker, feature]}, multi):
        assert read_area(json.dumps(doc), HOME).ring_ne == base.ring_ne
    coords = " ".join(f"{lon!r},{lat!r},0" for lon, lat in lonlat(ne))
    kml = (f'<?xml version="1.0"?><kml xmlns="http://www.opengis.net/kml/2.2"><Placemark>'
           f"<Polygon><outerBoundaryIs><LinearRing><coordinates>\n  {coords}\n"
           f"</coordinates></LinearRing></outerBoundaryIs></Polygon></Placemark></kml>")
    assert np.allclose(read_area(kml, HOME).ne, base.ne)
    inside = base.contains(np.array([[50.0, 400.0], [500.0, 100.0], [400.0, 400.0]]))
    assert inside.tolist() == [True, True, False]


def polygon_text(coords):
    return json.dumps({"type": "Polygon", "coordinates": coords})


SQUARE = lonlat([(0, 0), (0, 100), (100, 100), (100, 0)])
FAR = lonlat([(0, 0), (0, 100), (11_000, 100)])
KML_TWO = "<kml><Polygon/><Polygon/></kml>"
KML_HOLE = ("<kml><Polygon><outerBoundaryIs><LinearRing><coordinates>8.5,47.5 8.501,47.5 "
            "8.501,47.501</coordinates></LinearRing></outerBoundaryIs><innerBoundaryIs>"
            "<LinearRing><coordinates>8.5,47.5 8.5,47.5 8.5,47.5</coordinates></LinearRing>"
            "</innerBoundaryIs></Polygon></kml>")
BAD_AREAS = {
    "not JSON": ("{'type': 'Polygon'," + " x" * 40, "area"),
    "not GeoJSON": ('{"type": "Point", "coordinates": [8.5, 47.5]}', "area.type"),
    "a JSON list": ("[1, 2, 3]", "area.type"),
    "no polygon": ('{"type": "FeatureCollection", "features": []}', "area.features"),
    "two polygons": (json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "geometry": json.loads(polygon_text([SQUARE]))}] * 2}),
        "area.features"),
    "multipolygon of two": (json.dumps({"type": "MultiPolygon",
                                        "coordinates": [[SQUARE], [SQUARE]]}),
                            "area.coordinates"),
    "a hole": (polygon_text([SQUARE, SQUARE]), "area.coordinates"),
    "two vertices": (polygon_text([SQUARE[:2]]), "area.coordinates[0]"),
    "self-intersecting": (polygon_text([[SQUARE[0], SQUARE[2], SQUARE[1], SQUARE[3]]]),
                          "area.coordinates[0]"),
    "longitude out of range": (polygon_text([[SQUARE[0], [200.0, 47.5], SQUARE[2]]]),
                               "area.coordinates[0][1]"),
    "latitude first": (polygon_text([[p[::-1] for p in SQUARE]]), "area.coordinates[0][3]"),
    "too far": (polygon_text([FAR]), "area.coordinates[0][2]"),
    "zero size": (polygon_text([lonlat([(0, 0), (50, 50), (100, 100)])]),
                  "area.coordinates[0]"),
    "not a number": (polygon_text([[SQUARE[0], ["8.5", 47.5], SQUARE[2]]]),
                     "area.coordinates[0][1]"),
    "bad XML": ("<kml><Polygon>", "area"),
    "two KML polygons": (KML_TWO, "area.Polygon"),
    "KML hole": (KML_HOLE, "area.coordinates"),
    "KML bad tuple": ("<kml><Polygon><outerBoundaryIs><LinearRing><coordinates>8.5;47.5"
                      "</coordinates></LinearRing></outerBoundaryIs></Polygon></kml>",
                      "area.coordinates"),
}


@pytest.mark.parametrize("case", sorted(BAD_AREAS))
def test_a_bad_area_gets_a_one_line_error_naming_the_field(case):
    text, field = BAD_AREAS[case]
    with pytest.raises(ValueError) as info:
        read_area(text, HOME)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{field}: value ")
    quoted = message[len(f"{field}: value "):message.index(" is not allowed; expected ")]
    assert len(quoted) <= 40


def test_the_reader_says_why():
    def refusal(text, home=HOME):
        with pytest.raises(ValueError) as info:
            read_area(text, home)
        return str(info.value)

    assert "without holes" in refusal(BAD_AREAS["a hole"][0])
    assert "simple ring" in refusal(BAD_AREAS["self-intersecting"][0])
    assert "within 10000 m of the home" in refusal(BAD_AREAS["too far"][0])
    assert "longitude first" not in refusal(BAD_AREAS["too far"][0])
    assert "longitude first" in refusal(BAD_AREAS["latitude first"][0])
    assert "at least 1 m^2" in refusal(BAD_AREAS["zero size"][0])
    assert "at least 3 distinct" in refusal(BAD_AREAS["two vertices"][0])
    assert "longitude first" in refusal(BAD_AREAS["longitude out of range"][0])
    assert refusal(polygon_text([SQUARE]), Home(89.5, 8.5, 0.0)).startswith("home: ")


@pytest.mark.parametrize("name, kwargs", [
    ("swath_m", {"swath_m": 0.0}), ("look_offset_m", {"look_offset_m": -1.0}),
    ("overlap", {"overlap": 1.0}), ("run_in_m", {"run_in_m": math.nan}),
    ("bearing_rad", {"bearing_rad": math.inf})])
def test_bad_layout_parameters_name_the_parameter(name, kwargs):
    area = area_of(SHAPES["rectangle"])
    args = {"bearing_rad": 0.0, "swath_m": S0, "look_offset_m": LOOK, "overlap": 0.1,
            "run_in_m": 0.0} | kwargs
    with pytest.raises(ValueError, match=rf"^{name}: value .* is not allowed; expected"):
        layout_strips(area, **args)
    with pytest.raises(ValueError, match=r"^step_deg: "):
        best_bearing(area, lambda b: 0.0, step_deg=0.0)
    with pytest.raises(ValueError, match=r"^cell_m: "):
        covered_fraction(area, [], S0, 0.0)
