"""`uav-insar survey` as a user runs it: a concave area surveyed end to end (strips on the look
side, coverage, run-ins, sorties in the battery, a .plan per UAV per sortie with AMSL heights,
GeoJSON for QGIS, survey.json for the planner and the report), the speed chosen for an
accuracy, and bad input refused in one line with nothing written."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from test_bad_input_cli import assert_one_line, run

from uav_insar_planner.mission_file.geodesy import latlon_to_ned, ned_to_latlon
from uav_insar_planner.mission_file.qgc_plan import CMD_DELAY, CMD_LOITER_UNLIM, CMD_WAYPOINT
from uav_insar_planner.survey.survey_file import read_survey
from uav_insar_planner.track.speed_profile import RAMP_MPS2

HOME = (48.1, 11.5, 520.0)
HOME_ARG = ",".join(map(str, HOME))
# An L of 240 m x 200 m north-east of the home, its notch 120 m x 110 m; the station inside.
L_NE = [(40, 60), (40, 300), (150, 300), (150, 180), (240, 180), (240, 60)]
STATION_NE = (120.0, 150.0)


def _lonlat(points_ne):
    return [[ned_to_latlon(HOME[0], HOME[1], n, e)[1], ned_to_latlon(HOME[0], HOME[1], n, e)[0]]
            for n, e in points_ne]


def _write_area(tmp_path: Path, points_ne=L_NE, name: str = "area.geojson") -> Path:
    ring = _lonlat(points_ne)
    path = tmp_path / name
    path.write_text(json.dumps({"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {}, "geometry": {
            "type": "Polygon", "coordinates": [ring + [ring[0]]]}}]}))
    return path


def _station() -> str:
    lat, lon = ned_to_latlon(HOME[0], HOME[1], *STATION_NE)
    return f"{lat},{lon}"


def _ne(lonlat):
    return latlon_to_ned(HOME[0], HOME[1], lonlat[1], lonlat[0])


def test_a_concave_area_is_surveyed_on_the_look_side_in_sorties_that_fit(capsys, tmp_path):
    area, out = _write_area(tmp_path), tmp_path / "survey"
    code, stdout, err = run(capsys, "survey", str(area), "--home", HOME_ARG, "--station",
                            _station(), "--out", str(out), "--endurance-min", "6",
                            "--autopilot", "px4", "--json")
    assert code == 0, err
    summary = json.loads(stdout)
    assert summary["covered_fraction"] >= 0.995
    v = summary["speed_mps"]
    assert summary["run_in_m"] >= v * v / (2 * RAMP_MPS2)
    budget = 6 * 60 * (1 - 0.2)
    assert len(summary["sorties"]) >= 2  # a 6-minute battery: more than one sortie
    assert all(s["flight_time_s"] <= budget for s in summary["sorties"])
    flown = sorted(i for s in summary["sorties"] for i in s["strips"])
    assert flown == list(range(summary["strips"]))
    doc = json.loads((out / "survey.geojson").read_text())
    kinds = [f["properties"]["kind"] for f in doc["features"]]
    assert kinds.count("strip") == kinds.count("swath") == summary["strips"]
    strips = {f["properties"]["index"]: f for f in doc["features"]
              if f["properties"]["kind"] == "strip"}
    for f in doc["features"]:
        if f["properties"]["kind"] != "swath":
            continue
        # S_0 wide, centred z_0 tan(theta_0) right of the direction of flight (C2)
        corners = [_ne(p) for p in f["geometry"]["coordinates"][0][:4]]
        assert math.dist(corners[0], corners[1]) == pytest.approx(summary["swath_m"], abs=0.05)
        (n0, e0), (n1, e1) = (_ne(p) for p in strips[f["properties"]["index"]]
                              ["geometry"]["coordinates"])
        cn = sum(c[0] for c in corners) / 4 - n0
        ce = sum(c[1] for c in corners) / 4 - e0
        right = ((n1 - n0) * ce - (e1 - e0) * cn) / math.hypot(n1 - n0, e1 - e0)
        assert right > 0.5 * summary["swath_m"] - 1e-6  # on the right, beyond half a swath
    plans = sorted(p.name for p in out.glob("sortie*_uav*.plan"))
    assert len(plans) == 3 * len(summary["sorties"])
    for name in plans:
        items = json.loads((out / name).read_text())["mission"]["items"]
        heights = {round(i["params"][6], 3) for i in items if i["command"] == CMD_WAYPOINT}
        assert len(heights) == 1 and heights.pop() > HOME[2]  # AMSL: the home's 520 m + z_k
        sortie = int(name[6:name.index("_")]) - 1
        holds = [i for i in items if i["command"] == CMD_LOITER_UNLIM]
        assert len(holds) == len(summary["sorties"][sortie]["strips"])
        assert summary["mission_start_items"][name] == [
            n for n, i in enumerate(items) if i["command"] == 178 and i["params"][1] == v]
    # survey.json, read back: the strips the GeoJSON draws, the sorties and speed printed
    survey = read_survey((out / "survey.json").read_text())
    assert len(survey.strips) == summary["strips"] and survey.speed_mps == v
    assert [list(s) for s in survey.sorties] == [s["strips"] for s in summary["sorties"]]
    assert survey.sigma_h_m == summary["sigma_h_m"] and survey.swath_m == summary["swath_m"]
    assert survey.station_ne_m == pytest.approx(STATION_NE, abs=1e-6)
    for strip in survey.strips:
        drawn = [_ne(p) for p in strips[strip.index]["geometry"]["coordinates"]]
        for a, b in zip(strip.master_line_ne(), drawn, strict=True):
            assert a == pytest.approx(b, abs=0.01)  # the GeoJSON's 1e-8 deg: about 1 mm
        assert survey.num_slots[strip.index] == strips[strip.index]["properties"]["num_slots"]


def test_the_speed_for_an_accuracy_is_certified_and_a_smaller_survey_clears_stale_plans(
        capsys, tmp_path):
    area, out = _write_area(tmp_path), tmp_path / "survey"
    common = ["survey", str(area), "--home", HOME_ARG, "--station", _station(), "--out",
              str(out), "--json"]
    code, stdout, err = run(capsys, *common, "--endurance-min", "6")
    assert code == 0, err
    before = sorted(p.name for p in out.glob("sortie*.plan"))
    code, stdout, err = run(capsys, *common, "--speed", "auto", "--sigma-h-max", "0.072",
                            "--endurance-min", "60")
    assert code == 0, err
    summary = json.loads(stdout)
    assert summary["sigma_h_m"] <= 0.072 < 0.0736  # slower than Table I's 4.3 m/s
    assert summary["speed_mps"] < 4.3 and "lower bound" in summary["speed_why"]
    assert len(summary["sorties"]) == 1
    after = sorted(p.name for p in out.glob("sortie*.plan"))
    assert len(before) > len(after) == 3  # the earlier survey's sortie 2.. plans removed
    items = json.loads((out / after[0]).read_text())["mission"]["items"]
    assert sum(i["command"] == CMD_DELAY for i in items) == summary["strips"]


FAR_NE = [(20000 + n, e) for n, e in L_NE]
BAD = {
    "not json": ("{not json", "expected GeoJSON or KML"),
    "no polygon": ('{"type": "Point", "coordinates": [11.5, 48.1]}', "Polygon"),
    "bow tie": (None, "self-intersect"),
    "20 km away": (None, "10"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_a_bad_area_is_refused_in_one_line_and_nothing_is_written(capsys, tmp_path, case):
    text, says = BAD[case]
    if case == "bow tie":
        path = _write_area(tmp_path, [(40, 60), (240, 300), (240, 60), (40, 300)])
    elif case == "20 km away":
        path = _write_area(tmp_path, FAR_NE)
    else:
        path = tmp_path / "area.geojson"
        path.write_text(text)
    out = tmp_path / "survey"
    code, _, err = run(capsys, "survey", str(path), "--home", HOME_ARG, "--out", str(out))
    assert_one_line(code, err, says)
    assert not out.exists()


@pytest.mark.parametrize(("extra", "says", "exit_code"), [
    (["--endurance-min", "1"], "endurance_min", 2),  # no strip fits a 1-minute battery
    (["--speed", "auto", "--sigma-h-max", "0.01"], "sigma_h_max", 3),  # no speed is that good
    (["--speed", "auto"], "speed", 2),
    (["--overlap", "1.5"], "--overlap", 2),
    (["--speed", "9"], "speed", 3),  # past the C9/C10 edge at Table I
])
def test_a_survey_that_cannot_be_flown_says_why_in_one_line(capsys, tmp_path, extra, says,
                                                            exit_code):
    area, out = _write_area(tmp_path), tmp_path / "survey"
    code, _, err = run(capsys, "survey", str(area), "--home", HOME_ARG, "--station",
                       _station(), "--out", str(out), *extra)
    assert_one_line(code, err, says, exit_code)
    assert not out.exists()


def test_a_station_too_far_from_the_strips_is_named(capsys, tmp_path):
    area, out = _write_area(tmp_path), tmp_path / "survey"
    code, _, err = run(capsys, "survey", str(area), "--home", HOME_ARG, "--out", str(out))
    assert_one_line(code, err, "station", 3)  # at the home: the far strips' C9/C10 fail
    assert "strip" in err and not out.exists()
