"""A survey's `.plan` per UAV per sortie (mission_file/survey_plan.py): every strip's entry and
end where the strip's formation frame puts this UAV, AMSL heights, a wait per strip, and the
item MISSION_START resumes each strip from on PX4."""
from __future__ import annotations

import math
from datetime import datetime, timezone

import pytest

from uav_insar_planner.mission_file.geodesy import latlon_to_ned
from uav_insar_planner.mission_file.qgc_plan import (
    CMD_CHANGE_SPEED,
    CMD_DELAY,
    CMD_LOITER_UNLIM,
    CMD_RTL,
    CMD_WAYPOINT,
    PX4_PASS_SEQ,
    Home,
    Pass,
    mission_items,
)
from uav_insar_planner.mission_file.survey_plan import StripLeg, sortie_document, sortie_items
from uav_insar_planner.track.frame import TrackFrame

HOME = Home(48.1, 11.5, 520.0)
V, TRANSIT, RUN_IN, LENGTH = 4.3, 5.0, 8.0, 86.0
T0 = datetime(2026, 12, 6, 12, 0, 0, tzinfo=timezone.utc)


def _legs(start: bool) -> list[StripLeg]:
    """Two strips along bearing 30 deg, the second flown back 40 m to the side."""
    out = TrackFrame.from_degrees(30.0, (0.0, 0.0, 0.0))
    back = TrackFrame.from_degrees(210.0, out.to_ned(-40.0, LENGTH, 0.0))
    return [StripLeg(out, LENGTH, RUN_IN, T0 if start else None),
            StripLeg(back, LENGTH, RUN_IN, T0.replace(minute=2) if start else None)]


def _ne(item: dict) -> tuple[float, float]:
    lat, lon = item["params"][4:6]
    return latlon_to_ned(HOME.lat_deg, HOME.lon_deg, lat, lon)


def test_each_strip_is_entered_waited_for_and_flown_at_v_y_where_its_frame_puts_the_uav():
    x, z = -25.0, 60.0
    legs = _legs(True)
    items, seqs = sortie_items(HOME, legs, x, z, V, TRANSIT)
    commands = [i["command"] for i in items]
    assert commands.count(CMD_DELAY) == 2 and commands[-1] == CMD_RTL
    for leg, seq in zip(legs, seqs, strict=True):
        speed, end = items[seq], items[seq + 1]  # (PX4's seq: the .plan's index)
        assert speed["command"] == CMD_CHANGE_SPEED and speed["params"][1] == V
        entry = items[seq - 2]
        assert entry["command"] == CMD_WAYPOINT and end["command"] == CMD_WAYPOINT
        for item, y in ((entry, -RUN_IN), (end, LENGTH)):
            n, e, _ = leg.frame.to_ned(x, y, 0.0)
            assert _ne(item) == pytest.approx((n, e), abs=0.01)
            assert item["params"][6] == pytest.approx(HOME.alt_m + z)  # AMSL
            assert item["AltitudeMode"] == 2
        assert items[seq - 1]["params"][1:4] == [leg.start.hour, leg.start.minute,
                                                 leg.start.second]
    # the turn: from the first strip's end to the second's entry: the UAV crosses to the
    # other side of the master line (40 m across), and the second's run-in lies beyond y = 86
    first_end, second_entry = items[seqs[0] + 1], items[seqs[1] - 2]
    assert math.dist(_ne(first_end), _ne(second_entry)) == pytest.approx(
        math.hypot(40.0 + 2 * x, RUN_IN), abs=0.05)


def test_one_strip_is_the_single_pass_export_items_and_px4_holds_at_each_strip():
    leg = StripLeg(TrackFrame.from_degrees(30.0), LENGTH, RUN_IN, None)
    items, seqs = sortie_items(HOME, [leg], 5.0, 50.0, V, TRANSIT)
    single = mission_items(HOME, Pass(V, LENGTH, RUN_IN, 30.0), 5.0, 50.0, None, "rtl")
    # the same take-off, entry, hold, speed, end and return, with a transit speed set first
    assert [i["command"] for i in items] == [single[0]["command"], CMD_CHANGE_SPEED] + [
        i["command"] for i in single[1:]]
    assert seqs == [PX4_PASS_SEQ + 1]
    doc = sortie_document(HOME, _legs(False), 0.0, 50.0, V, TRANSIT, "px4")
    assert [i["command"] for i in doc["mission"]["items"]].count(CMD_LOITER_UNLIM) == 2
    with pytest.raises(ValueError, match="^start: an ardupilot file waits"):
        sortie_document(HOME, _legs(False), 0.0, 50.0, V, TRANSIT, "ardupilot")
    with pytest.raises(ValueError, match="^start: an px4 file holds"):
        sortie_document(HOME, _legs(True), 0.0, 50.0, V, TRANSIT, "px4")
