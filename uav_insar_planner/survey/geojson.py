"""The planned survey as a GeoJSON FeatureCollection (RFC 7946: [lon, lat]) that QGIS and
geojson.io open: the area, each strip's master ground track over its imaged part (slot 0's
line to the last slot's end) and each strip's swath, with `properties.kind` saying which."""
from __future__ import annotations

from collections.abc import Sequence

from uav_insar_planner.mission_file.geodesy import ned_to_latlon
from uav_insar_planner.survey.planning import SurveyPlan


def _lonlat(survey: SurveyPlan, points_ne: Sequence[tuple[float, float]]) -> list[list[float]]:
    home = survey.area.home
    out = []
    for n, e in points_ne:
        lat, lon = ned_to_latlon(home.lat_deg, home.lon_deg, n, e)
        out.append([round(lon, 8), round(lat, 8)])
    return out


def survey_geojson(survey: SurveyPlan) -> dict:
    """The FeatureCollection of `survey` (module docstring)."""
    sortie_of = {i: s for s, sortie in enumerate(survey.sorties) for i in sortie.strips}
    ring = [list(p) for p in survey.area.ring_lonlat]
    features = [{"type": "Feature", "geometry": {"type": "Polygon",
                                                  "coordinates": [ring + [ring[0]]]},
                 "properties": {"kind": "area", "area_m2": round(survey.area.area_m2, 1),
                                "covered_fraction": survey.covered_fraction}}]
    for sp in survey.strips:
        s = sp.strip
        features.append({"type": "Feature", "geometry": {
            "type": "LineString", "coordinates": _lonlat(survey, s.master_line_ne())},
            "properties": {"kind": "strip", "index": s.index, "sortie": sortie_of[s.index],
                           "direction": s.direction, "run_in_m": s.track.run_in_m,
                           "speed_mps": survey.speed_mps, "num_slots": sp.num_slots}})
        corners = _lonlat(survey, s.swath_ne())
        features.append({"type": "Feature", "geometry": {
            "type": "Polygon", "coordinates": [corners + [corners[0]]]},
            "properties": {"kind": "swath", "index": s.index, "width_m": s.swath_m}})
    return {"type": "FeatureCollection", "features": features}
