"""A survey's strips share one certified formation; each strip's offloading is checked by the
station disk (survey/planning.py strip_plan), which must say what the independent evaluator
says of the same schedule: feasible where it is, and the same failing families where not."""
from __future__ import annotations

import pytest

from uav_insar_planner import load_params
from uav_insar_planner.evaluate import evaluate
from uav_insar_planner.mission_file.qgc_plan import Home
from uav_insar_planner.solver import solve
from uav_insar_planner.survey.area import read_area
from uav_insar_planner.survey.planning import geometry, strip_plan
from uav_insar_planner.survey.strips import layout_strips
from uav_insar_planner.track.passes import run_in_m

HOME = Home(48.1, 11.5, 520.0)
# 300 m x 400 m north-east of the home
AREA = ('{"type": "Polygon", "coordinates": [[[11.5008, 48.1004], [11.5048, 48.1004], '
        '[11.5048, 48.1031], [11.5008, 48.1031], [11.5008, 48.1004]]]}')


@pytest.mark.parametrize("station", [(150.0, 210.0), (0.0, 0.0), (150.0, 60.0), (-300.0, 500.0)])
def test_the_station_disk_says_what_the_evaluator_says_of_every_strip(station):
    params = load_params()
    plan = solve(params)
    swath, offset, _ = geometry(params, plan)
    strips = layout_strips(read_area(AREA, HOME), 0.0, swath, offset, 0.2,
                           run_in_m(params.speed))
    verdicts = []
    for strip in strips:
        sp, violated = strip_plan(params, plan, strip, station)
        local = params.replace(num_slots=sp.num_slots, ground_station_m=list(sp.station_m))
        ev = evaluate(local, plan.formation, sp.p_com_w, plan.scheme, plan.objective)
        assert sorted(set(ev.violated) & {"C9", "C11"}) == violated, (strip.index, station)
        assert ev.constraints["C10"].ok  # the cheapest schedule holds the rate by its making
        assert not set(ev.violated) - {"C9", "C11"}  # the rest are the formation's own
        verdicts.append(bool(violated))
    print(f"station {station}: {sum(verdicts)} of {len(strips)} strips out of its reach")
    if station == (150.0, 210.0):  # inside the area: most strips served
        assert sum(verdicts) <= len(verdicts) // 2
    if station == (-300.0, 500.0):  # far off: none
        assert all(verdicts)
