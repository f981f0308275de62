"""The planned survey as a machine-readable file (`survey.json`): what flying it strip after
strip and mapping what was flown need, and its reader.

`survey_document(survey, params)` is a JSON object, SI units, angles in radians:

    format "uav_insar_planner survey", version 1
    home            {lat_deg, lon_deg, alt_m}               take-off and landing, AMSL
    area            {ring_lonlat, ring_ne_m}                 the polygon, counter-clockwise,
                                                             no closing point; (north, east)
                                                             metres about the home
    speed_mps slot_duration_s swath_m look_offset_m bearing_rad run_in_m
    station_ne_m    [north, east]                            the ground station about the home
    formation       per UAV [x_m, z_m], null for a UAV not flown (the shared certified plan)
    sigma_h_m lower_bound_m                                  its sigma_h and certified lower
                                                             bound (null: none)
    strips          per strip, in flight order: index, band, direction, centre_x_m, y_start_m,
                    length_m, num_slots (survey/strips.py Strip; its master line x_m is
                    centre_x_m - direction look_offset_m, as the layout lays it)
    sorties         per sortie its strip indices, in flight order

`read_survey(text)` gives a SurveyFile back: the area re-read through survey/area.py (the same
projection, so `ring_ne_m` must be the ring's own, to a micrometre), the strips rebuilt as
Strip objects, so `Strip.frame(x0)`, `master_line_ne` and `swath_ne` work as on the plan. Every
field is checked; anything else is refused with a one-line ValueError naming the field, the
value cut short and what is allowed. Unknown fields are refused too: a new field is a new
version.
"""
from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from uav_insar_planner.mission_file.geodesy import POLE_MARGIN_DEG
from uav_insar_planner.mission_file.qgc_plan import Home
from uav_insar_planner.params import Params
from uav_insar_planner.survey.area import MAX_DISTANCE_M, SHORT_CHARS, Area, read_area
from uav_insar_planner.survey.strips import Strip
from uav_insar_planner.swarm import count_problem
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.passes import TrackPass

if TYPE_CHECKING:  # the reader needs no solver: the planner node and the report read files
    from uav_insar_planner.survey.planning import SurveyPlan

FORMAT = "uav_insar_planner survey"
VERSION = 1
HOME_ALT_MAX_M = 1.0e4  # as `--home` takes it
RING_TOLERANCE_M = 1e-6  # ring_ne_m against the ring re-projected (the same function: exact)
SLOTS_TOLERANCE = 1e-6  # length_m against num_slots whole slots, relative
MAX_SLOTS = 1_000_000
TOP = ("format", "version", "home", "area", "speed_mps", "slot_duration_s", "swath_m",
       "look_offset_m", "bearing_rad", "run_in_m", "station_ne_m", "formation", "sigma_h_m",
       "lower_bound_m", "strips", "sorties")
STRIP = ("index", "band", "direction", "centre_x_m", "y_start_m", "length_m", "num_slots")


@dataclass(frozen=True)
class SurveyFile:
    """A survey read back (module docstring). `num_slots[i]` is strip i's slot count;
    `formation[k]` UAV k's (x, z) [m] or None; `lower_bound_m` NaN when the plan had none."""

    home: Home
    area: Area
    speed_mps: float
    slot_duration_s: float
    swath_m: float
    look_offset_m: float
    bearing_rad: float
    run_in_m: float
    station_ne_m: tuple[float, float]
    formation: tuple[tuple[float, float] | None, ...]
    sigma_h_m: float
    lower_bound_m: float
    strips: tuple[Strip, ...]
    num_slots: tuple[int, ...]
    sorties: tuple[tuple[int, ...], ...]

    @property
    def master_x_m(self) -> float:
        """The master's across-track x_0 in the formation [m]."""
        master = self.formation[0]
        assert master is not None  # read_survey refuses a formation without its master
        return master[0]

    def frame(self, index: int) -> TrackFrame:
        """Strip `index`'s track frame about the home, the master on its master line."""
        return self.strips[index].frame(self.master_x_m)


def survey_document(survey: SurveyPlan, params: Params) -> dict:
    """The JSON object of `survey` planned under `params` (module docstring)."""
    plan, first = survey.plan, survey.strips[0].strip
    return {
        "format": FORMAT, "version": VERSION,
        "home": {"lat_deg": survey.area.home.lat_deg, "lon_deg": survey.area.home.lon_deg,
                 "alt_m": survey.area.home.alt_m},
        "area": {"ring_lonlat": [list(p) for p in survey.area.ring_lonlat],
                 "ring_ne_m": [list(p) for p in survey.area.ring_ne]},
        "speed_mps": survey.speed_mps, "slot_duration_s": params.slot_duration_s,
        "swath_m": first.swath_m, "look_offset_m": first.look_offset_m,
        "bearing_rad": survey.bearing_rad, "run_in_m": survey.run_in_m,
        "station_ne_m": [float(v) for v in survey.options.station_ne_m],
        "formation": [[float(x), float(z)] if math.isfinite(x) and math.isfinite(z) else None
                      for x, z in plan.formation],
        "sigma_h_m": float(plan.sigma_h_m),
        "lower_bound_m": (float(plan.lower_bound_m) if math.isfinite(plan.lower_bound_m)
                          else None),
        "strips": [{"index": sp.strip.index, "band": sp.strip.band,
                    "direction": sp.strip.direction, "centre_x_m": sp.strip.centre_x_m,
                    "y_start_m": sp.strip.track.y_start_m, "length_m": sp.strip.track.length_m,
                    "num_slots": sp.num_slots} for sp in survey.strips],
        "sorties": [list(s.strips) for s in survey.sorties],
    }


def _refuse(field: str, value: Any, expected: str) -> ValueError:
    text = repr(value)  # survey/area.py's style: the value cut short
    text = text if len(text) <= SHORT_CHARS else text[:SHORT_CHARS - 3] + "..."
    return ValueError(f"{field}: value {text} is not allowed; expected {expected}")


def _object(value: Any, field: str, keys: tuple[str, ...]) -> Mapping[str, Any]:
    """`value` as an object with exactly `keys` (one line for the first missing or unknown)."""
    if not isinstance(value, dict):
        raise _refuse(field, value, f"an object with {', '.join(keys)}")
    prefix = f"{field}." if field else ""
    for key in keys:
        if key not in value:
            raise ValueError(f"{prefix}{key}: missing; expected it in every {FORMAT} "
                             f"version {VERSION}")
    for key in value:
        if key not in keys:
            raise _refuse(f"{prefix}{key}", value[key], f"no field {str(key)[:SHORT_CHARS]!r} "
                          f"in {FORMAT} version {VERSION} (only {', '.join(keys)})")
    return value


def _real(value: Any, field: str, low: float, high: float, above: bool = False,
          unit: str = "") -> float:
    """A finite number in [low, high] ((low, high] when `above`)."""
    ok = (isinstance(value, (int, float)) and not isinstance(value, bool)
          and math.isfinite(value) and (value > low if above else value >= low)
          and value <= high)
    if not ok:
        bracket = "(" if above else "["
        raise _refuse(field, value, f"a finite number in {bracket}{low:g}, {high:g}]{unit}")
    return float(value)


def _int(value: Any, field: str, low: int, high: int) -> int:
    if not (isinstance(value, int) and not isinstance(value, bool) and low <= value <= high):
        raise _refuse(field, value, f"an integer in [{low}, {high}]")
    return value


def _list(value: Any, field: str, expected: str, length: int | None = None) -> list:
    if not isinstance(value, list) or (length is not None and len(value) != length) or (
            length is None and not value):
        raise _refuse(field, value, expected)
    return value


def _home(value: Any) -> Home:
    doc = _object(value, "home", ("lat_deg", "lon_deg", "alt_m"))
    lat_max = 90.0 - POLE_MARGIN_DEG
    return Home(_real(doc["lat_deg"], "home.lat_deg", -lat_max, lat_max, unit=" deg"),
                _real(doc["lon_deg"], "home.lon_deg", -180.0, 180.0, unit=" deg"),
                _real(doc["alt_m"], "home.alt_m", -HOME_ALT_MAX_M, HOME_ALT_MAX_M,
                      unit=" m AMSL"))


def _area(value: Any, home: Home) -> Area:
    """The area re-read by survey/area.py from ring_lonlat; ring_ne_m checked against it."""
    doc = _object(value, "area", ("ring_lonlat", "ring_ne_m"))
    ring = _list(doc["ring_lonlat"], "area.ring_lonlat", "a list of at least 3 [lon, lat]")
    try:
        area = read_area(json.dumps({"type": "Polygon", "coordinates": [ring]}), home)
    except (ValueError, TypeError) as exc:
        raise ValueError(str(exc).replace("area.coordinates[0]", "area.ring_lonlat")) from None
    ne = _list(doc["ring_ne_m"], "area.ring_ne_m", f"{len(area.ring_ne)} [north, east] "
               "pairs, the ring's", len(area.ring_ne))
    if len(area.ring_ne) != len(ring):  # read_area dropped repeats or turned the ring
        raise _refuse("area.ring_lonlat", ring, "the ring counter-clockwise, without repeated "
                      "or closing points (as survey_document writes it)")
    for i, (point, own) in enumerate(zip(ne, area.ring_ne, strict=True)):
        field = f"area.ring_ne_m[{i}]"
        pair = _list(point, field, "[north, east] in metres", 2)
        n, e = (_real(v, field, -MAX_DISTANCE_M, MAX_DISTANCE_M) for v in pair)
        if math.hypot(n - own[0], e - own[1]) > RING_TOLERANCE_M:
            raise _refuse(field, point, f"ring_lonlat[{i}] projected about the home, "
                          f"[{own[0]:.6f}, {own[1]:.6f}]")
    return area


def _formation(value: Any) -> tuple[tuple[float, float] | None, ...]:
    rows = _list(value, "formation", "a list of [x_m, z_m] or null, one per UAV")
    if problem := count_problem("formation", len(rows)):
        raise ValueError(problem)
    out: list[tuple[float, float] | None] = []
    for k, row in enumerate(rows):
        field = f"formation[{k}]"
        if row is None and k > 0:
            out.append(None)
            continue
        pair = _list(row, field, "[x_m, z_m] (null only for a slave not flown)", 2)
        out.append((_real(pair[0], field, -1e5, 1e5, unit=" m across track"),
                    _real(pair[1], field, 0.0, 1e5, True, " m above the ground")))
    if sum(r is not None for r in out) < 2:
        raise _refuse("formation", rows, "the master and at least one slave flown")
    return tuple(out)


def _strip(value: Any, i: int, top: Mapping[str, float]) -> tuple[Strip, int]:
    field = f"strips[{i}]"
    doc = _object(value, field, STRIP)
    if doc["index"] != i or not isinstance(doc["index"], int) or isinstance(doc["index"], bool):
        raise _refuse(f"{field}.index", doc["index"], f"{i} (the strips in flight order)")
    band = _int(doc["band"], f"{field}.band", 0, MAX_SLOTS)
    direction = doc["direction"]
    if not (isinstance(direction, int) and not isinstance(direction, bool)
            and direction in (1, -1)):
        raise _refuse(f"{field}.direction", direction, "1 (along the bearing) or -1")
    centre = _real(doc["centre_x_m"], f"{field}.centre_x_m", -MAX_DISTANCE_M, MAX_DISTANCE_M)
    y_start = _real(doc["y_start_m"], f"{field}.y_start_m", -MAX_DISTANCE_M, MAX_DISTANCE_M)
    length = _real(doc["length_m"], f"{field}.length_m", 0.0, 2 * MAX_DISTANCE_M, True)
    slots = _int(doc["num_slots"], f"{field}.num_slots", 1, MAX_SLOTS)
    slot_m = top["speed_mps"] * top["slot_duration_s"]
    if abs(length - slots * slot_m) > SLOTS_TOLERANCE * max(length, 1.0):
        raise _refuse(f"{field}.num_slots", slots, f"length_m / (speed_mps slot_duration_s) "
                      f"= {length / slot_m:.6g} whole slots")
    track = TrackPass(centre - direction * top["look_offset_m"], y_start, length, direction,
                      top["run_in_m"])
    return Strip(i, band, direction, centre, track, top["bearing_rad"], top["swath_m"],
                 top["look_offset_m"]), slots


def _sorties(value: Any, count: int) -> tuple[tuple[int, ...], ...]:
    expected = f"strips 0..{count - 1}, each once, in flight order, split into sorties"
    rows = _list(value, "sorties", f"a list of sorties: {expected}")
    out = []
    for s, row in enumerate(rows):
        indices = _list(row, f"sorties[{s}]", "a non-empty list of strip indices")
        out.append(tuple(_int(v, f"sorties[{s}][{j}]", 0, count - 1)
                         for j, v in enumerate(indices)))
    if [i for row in out for i in row] != list(range(count)):
        raise _refuse("sorties", rows, expected)
    return tuple(out)


def read_survey(text: str) -> SurveyFile:
    """The survey in `text` (module docstring); ValueError, one line naming the field."""
    try:
        doc = json.loads(text)
    except (json.JSONDecodeError, TypeError) as exc:
        why = (f"{exc.msg} at line {exc.lineno} column {exc.colno}"
               if isinstance(exc, json.JSONDecodeError) else "not text")
        raise _refuse("survey", text, f"a JSON {FORMAT} file ({why})") from None
    if not isinstance(doc, dict):
        raise _refuse("survey", doc, f"a JSON object, a {FORMAT} file")
    if doc.get("format") != FORMAT:
        raise _refuse("format", doc.get("format"), f"{FORMAT!r} (is this a survey.json?)")
    if doc.get("version") != VERSION or isinstance(doc.get("version"), bool):
        raise _refuse("version", doc.get("version"), f"{VERSION} (this reader's; a survey of "
                      "another version needs the uav_insar_planner that wrote it)")
    doc = _object(doc, "", TOP)
    home = _home(doc["home"])
    area = _area(doc["area"], home)
    top = {"speed_mps": _real(doc["speed_mps"], "speed_mps", 0.0, 1000.0, True, " m/s"),
           "slot_duration_s": _real(doc["slot_duration_s"], "slot_duration_s", 0.0, 3600.0,
                                    True, " s"),
           "swath_m": _real(doc["swath_m"], "swath_m", 0.0, 1e5, True, " m"),
           "look_offset_m": _real(doc["look_offset_m"], "look_offset_m", 0.0, 1e5, unit=" m"),
           "bearing_rad": _real(doc["bearing_rad"], "bearing_rad", -2 * math.pi, 2 * math.pi),
           "run_in_m": _real(doc["run_in_m"], "run_in_m", 0.0, 1e4, unit=" m")}
    station = _list(doc["station_ne_m"], "station_ne_m", "[north, east] in metres", 2)
    station_ne = tuple(_real(v, "station_ne_m", -MAX_DISTANCE_M, MAX_DISTANCE_M, unit=" m")
                       for v in station)
    sigma = _real(doc["sigma_h_m"], "sigma_h_m", 0.0, 1e3, True, " m")
    bound = (math.nan if doc["lower_bound_m"] is None else _real(
        doc["lower_bound_m"], "lower_bound_m", 0.0, sigma * (1.0 + 1e-6), unit=" m (at most "
        "sigma_h_m), or null"))
    strips = _list(doc["strips"], "strips", "a non-empty list of strips")
    rebuilt = [_strip(s, i, top) for i, s in enumerate(strips)]
    return SurveyFile(
        home=home, area=area, station_ne_m=(station_ne[0], station_ne[1]),
        formation=_formation(doc["formation"]), sigma_h_m=sigma, lower_bound_m=bound,
        strips=tuple(s for s, _ in rebuilt), num_slots=tuple(n for _, n in rebuilt),
        sorties=_sorties(doc["sorties"], len(strips)), **top)
