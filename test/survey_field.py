"""A small field to survey, for the tests that fly one (not a test file): a rectangle east of
a home, strips north-south at Table I's v_y, and a battery that holds two of its three strips:
sortie 1 flies strips 0 and 1 (a turn between them), sortie 2 strip 2."""
from __future__ import annotations

import json
import math
from pathlib import Path

from uav_insar_planner.mission_file.qgc_plan import Home
from uav_insar_planner.params import params_from_mapping
from uav_insar_planner.survey.area import read_area
from uav_insar_planner.survey.planning import SurveyOptions, plan_survey
from uav_insar_planner.survey.survey_file import SurveyFile, read_survey, survey_document

NORTH_M = (0.0, 30.0)  # the field, metres about the home
EAST_M = (20.0, 140.0)
ENDURANCE_S = 220.0  # 176 s of flight after the 20 % reserve: two strips, not three
SPEED_MPS = 4.3


def ring(home: Home) -> list[list[float]]:
    """The field's (lon, lat) ring (closed)."""
    dlat = 1.0 / 111_320.0
    dlon = dlat / math.cos(math.radians(home.lat_deg))
    corners = ((NORTH_M[0], EAST_M[0]), (NORTH_M[0], EAST_M[1]), (NORTH_M[1], EAST_M[1]),
               (NORTH_M[1], EAST_M[0]), (NORTH_M[0], EAST_M[0]))
    return [[home.lon_deg + e * dlon, home.lat_deg + n * dlat] for n, e in corners]


def write_survey(folder: Path, home: Home) -> tuple[Path, SurveyFile]:
    """Plan the field's survey about `home`, write its survey.json into `folder`."""
    area = read_area(json.dumps({"type": "Polygon", "coordinates": [ring(home)]}), home)
    params = params_from_mapping({})
    options = SurveyOptions(bearing_rad=0.0, endurance_s=ENDURANCE_S, speed_mps=SPEED_MPS,
                            station_ne_m=(0.0, 0.0))
    survey = plan_survey(area, params, options)
    path = folder / "survey.json"
    path.write_text(json.dumps(survey_document(survey, params)))
    flown = read_survey(path.read_text())
    assert [len(s) for s in flown.sorties] == [2, 1], flown.sorties  # the field's design
    return path, flown
