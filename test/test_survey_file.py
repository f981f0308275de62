"""survey.json (survey/survey_file.py): a planned survey written and read back gives the same
strips (frames, master lines, swaths, lengths, slot counts), sorties, formation and area; every
field that is wrong is refused in one line naming it."""
from __future__ import annotations

import copy
import functools
import json
import math

import pytest

from uav_insar_planner import load_params
from uav_insar_planner.mission_file.geodesy import ned_to_latlon
from uav_insar_planner.mission_file.qgc_plan import Home
from uav_insar_planner.survey.area import read_area
from uav_insar_planner.survey.planning import SurveyOptions, SurveyPlan, plan_survey
from uav_insar_planner.survey.survey_file import read_survey, survey_document

HOME = Home(48.1, 11.5, 520.0)
# An L of 200 m x 240 m north-east of the home, its notch 90 m x 120 m; the station inside.
L_NE = [(40, 60), (40, 300), (150, 300), (150, 180), (240, 180), (240, 60)]
STATION_NE = (120.0, 150.0)
BEARING_RAD = 0.3  # off the grid's axes: no cell centre falls on a slot's edge by design


@functools.lru_cache(maxsize=1)
def planned_survey() -> SurveyPlan:
    """The L surveyed at Table I on BEARING_RAD, 6-minute batteries (several sorties)."""
    ring = [[ned_to_latlon(HOME.lat_deg, HOME.lon_deg, n, e)[1],
             ned_to_latlon(HOME.lat_deg, HOME.lon_deg, n, e)[0]] for n, e in L_NE]
    area = read_area(json.dumps({"type": "Polygon", "coordinates": [ring + [ring[0]]]}), HOME)
    return plan_survey(area, load_params(), SurveyOptions(
        bearing_rad=BEARING_RAD, station_ne_m=STATION_NE, endurance_s=360.0,
        speed_mps=load_params().speed))


def document() -> dict:
    return survey_document(planned_survey(), load_params())


def test_a_survey_written_and_read_back_is_the_same_survey():
    survey = planned_survey()
    assert len(survey.strips) >= 5 and len(survey.sorties) >= 2  # a case worth the name
    text = json.dumps(document(), indent=1)
    back = read_survey(text)
    x0 = float(survey.plan.formation[0, 0])
    assert back.master_x_m == x0
    assert len(back.strips) == len(survey.strips)
    for i, sp in enumerate(survey.strips):
        mine, theirs = back.frame(i), sp.strip.frame(x0)
        assert mine.bearing_rad == pytest.approx(theirs.bearing_rad, abs=1e-9)
        assert mine.origin_ned == pytest.approx(theirs.origin_ned, abs=1e-9)
        got = back.strips[i]
        assert got.track.length_m == pytest.approx(sp.strip.track.length_m, abs=1e-9)
        assert got.track.run_in_m == pytest.approx(sp.strip.track.run_in_m, abs=1e-9)
        assert back.num_slots[i] == sp.num_slots
        for a, b in zip(got.master_line_ne() + got.swath_ne(),
                        sp.strip.master_line_ne() + sp.strip.swath_ne(), strict=True):
            assert a == pytest.approx(b, abs=1e-9)
        assert (got.index, got.band, got.direction) == (sp.strip.index, sp.strip.band,
                                                        sp.strip.direction)
    assert back.sorties == tuple(s.strips for s in survey.sorties)
    assert back.area.ring_ne == survey.area.ring_ne
    assert back.area.ring_lonlat == survey.area.ring_lonlat
    assert back.home == HOME
    assert back.station_ne_m == STATION_NE
    assert back.speed_mps == survey.speed_mps and back.bearing_rad == BEARING_RAD
    assert back.slot_duration_s == load_params().slot_duration_s
    assert back.swath_m == survey.swath_m and back.run_in_m == survey.run_in_m
    assert back.sigma_h_m == survey.plan.sigma_h_m
    assert back.lower_bound_m == survey.plan.lower_bound_m <= back.sigma_h_m
    assert back.formation == tuple((float(x), float(z)) for x, z in survey.plan.formation)
    assert read_survey(json.dumps(survey_document(survey, load_params()))) == back


def _set(doc: dict, path: str, value) -> None:
    """doc at `path` ("a.b[1].c"; value ... deletes the key) set to `value`."""
    keys = [int(k) if k.isdigit() else k
            for k in path.replace("[", ".").replace("]", "").split(".")]
    where = doc
    for key in keys[:-1]:
        where = where[key]
    if value is ...:
        del where[keys[-1]]
    else:
        where[keys[-1]] = value


BAD = [  # (path, value, the message's start)
    ("format", "qgc plan", "format: value 'qgc plan'"),
    ("format", "x" * 5000, "format: value 'xxxx"),  # cut short: the line stays short
    ("version", 2, "version: value 2"),
    ("version", True, "version: value True"),
    ("speed_mps", ..., "speed_mps: missing"),
    ("colour", "red", "colour: value 'red'"),
    ("home", [48.1, 11.5, 520.0], "home: value [48.1"),
    ("home.lat_deg", 95.0, "home.lat_deg: value 95.0"),
    ("home.alt_m", ..., "home.alt_m: missing"),
    ("area.ring_lonlat", [[11.5, 48.1], [11.6, 48.1]], "area.ring_lonlat: value"),
    ("area.ring_lonlat[2]", [11.5, 95.0], "area.ring_lonlat[2]: value"),
    ("area.ring_ne_m[1]", [0.0, 0.0], "area.ring_ne_m[1]: value [0.0, 0.0]"),
    ("area.ring_ne_m", [[0.0, 0.0]], "area.ring_ne_m: value [[0.0, 0.0]]"),
    ("speed_mps", -4.3, "speed_mps: value -4.3"),
    ("speed_mps", "4.3", "speed_mps: value '4.3'"),
    ("speed_mps", float("nan"), "speed_mps: value nan"),
    ("slot_duration_s", 0, "slot_duration_s: value 0"),
    ("swath_m", None, "swath_m: value None"),
    ("look_offset_m", -1.0, "look_offset_m: value -1.0"),
    ("bearing_rad", 100.0, "bearing_rad: value 100.0"),
    ("run_in_m", -2.0, "run_in_m: value -2.0"),
    ("station_ne_m", [1.0], "station_ne_m: value [1.0]"),
    ("station_ne_m", [2e4, 0.0], "station_ne_m: value 20000.0"),
    ("formation", [[-27.1, 47.1]], "formation: value 1 UAVs"),
    ("formation[0]", None, "formation[0]: value None"),
    ("formation[1]", [-34.9, -48.2], "formation[1]: value -48.2"),
    ("formation[2]", [1.0, 2.0, 3.0], "formation[2]: value [1.0, 2.0, 3.0]"),
    ("sigma_h_m", 0.0, "sigma_h_m: value 0.0"),
    ("lower_bound_m", 1.0, "lower_bound_m: value 1.0"),
    ("strips", [], "strips: value []"),
    ("strips[1].index", 5, "strips[1].index: value 5"),
    ("strips[1].band", -1, "strips[1].band: value -1"),
    ("strips[1].direction", 0, "strips[1].direction: value 0"),
    ("strips[1].direction", 1.0, "strips[1].direction: value 1.0"),
    ("strips[1].centre_x_m", "left", "strips[1].centre_x_m: value 'left'"),
    ("strips[1].y_start_m", ..., "strips[1].y_start_m: missing"),
    ("strips[1].length_m", -5.0, "strips[1].length_m: value -5.0"),
    ("strips[1].num_slots", 3, "strips[1].num_slots: value 3"),
    ("strips[1].num_slots", 0, "strips[1].num_slots: value 0"),
    ("strips[1].sortie", 0, "strips[1].sortie: value 0"),
    ("sorties", [[0, 1]], "sorties: value [[0, 1]]"),
    ("sorties[0]", [], "sorties[0]: value []"),
    ("sorties[0][0]", "0", "sorties[0][0]: value '0'"),
    ("sorties[0][0]", 99, "sorties[0][0]: value 99"),
]


@pytest.mark.parametrize(("path", "value", "says"), BAD, ids=[f"{p}={str(v)[:12]}"
                                                               for p, v, _ in BAD])
def test_every_bad_field_is_refused_in_one_line_naming_it(path, value, says):
    doc = copy.deepcopy(document())
    _set(doc, path, value)
    with pytest.raises(ValueError) as caught:
        read_survey(json.dumps(doc))
    line = str(caught.value)
    assert line.startswith(says), line
    assert "\n" not in line and len(line) < 400, line
    assert "not allowed" in line or "missing" in line, line


def test_the_order_of_sorties_is_the_flight_order():
    doc = copy.deepcopy(document())
    flat = [i for s in doc["sorties"] for i in s]
    doc["sorties"] = [flat[::-1]]  # every strip once, backwards
    with pytest.raises(ValueError, match=r"^sorties: value .*in flight order"):
        read_survey(json.dumps(doc))
    doc["sorties"] = [flat]  # one sortie of them all, in order: a survey file may say so
    assert read_survey(json.dumps(doc)).sorties == (tuple(flat),)


@pytest.mark.parametrize(("text", "says"), [
    ("{not json", "survey: value '{not json' is not allowed; expected a JSON"),
    ("[1, 2]", "survey: value [1, 2] is not allowed; expected a JSON object"),
    ('{"format": "uav_insar_planner survey", "version": 1}', "home: missing"),
])
def test_what_is_no_survey_file_is_refused_in_one_line(text, says):
    with pytest.raises(ValueError) as caught:
        read_survey(text)
    assert str(caught.value).startswith(says) and "\n" not in str(caught.value)


def test_a_slave_not_flown_and_no_lower_bound_are_read_as_none_and_nan():
    doc = copy.deepcopy(document())
    doc["formation"][2] = None
    doc["lower_bound_m"] = None
    back = read_survey(json.dumps(doc))
    assert back.formation[2] is None and math.isnan(back.lower_bound_m)
