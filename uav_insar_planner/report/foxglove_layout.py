"""A Foxglove layout for a recorded mission (no ROS import): `foxglove_layout()` is the layout
as Foxglove exports it (`configById`, `globalVariables`, `userNodes`, `playbackConfig` and
`layout`, a mosaic tree of panel ids `Type!name`), one plot series per UAV of the mission
(`foxglove_layout(num_uavs)`):

  3D!markers                  /formation/markers and /formation/markers/flown, display frame
                              insar_track (there is no tf: every marker is in that frame)
  Plot!rate                   /uavK/achieved_rate.data [bit/s] per UAV
  Plot!power                  /uavK/offload.data[i] [W], i the index of power_w in the
                              offload message (ros/topics.py OFFLOAD_FIELDS)
  Plot!position_error         per UAV, the value `position_error_m` of the planner's status
                              `planner: uavK` on /diagnostics (a string: Foxglove's Plot reads
                              it as a number), through message-path filters
  DiagnosticSummary!all       every status on /diagnostics
  DiagnosticStatusPanel!plan  the planner's plan status in detail
  RawMessages!formation       /formation

Topic names are the suite's (ros/topics.py, which imports rclpy and so cannot be imported
here; test/test_foxglove_layout.py holds both to the same names and to a recorded bag).
Any swarm of swarm.py's sizes (MIN_UAVS..MAX_UAVS) has its layout: the plots get one series
per UAV, the other panels do not depend on the count. SHIPPED is the layout generated for
Table I's swarm (swarm.DEFAULT_NUM_UAVS), shipped as package data; `python -m
uav_insar_planner.report.foxglove_layout` writes it again. `uav-insar report` writes the
layout for the number of UAVs in the bag beside its plots.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from uav_insar_planner.published import (
    HARDWARE_ID,
    PLAN_STATUS_NAME,
    POSITION_ERROR_KEY,
    uav_status_name,
)
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, count_problem, uav_name, uavs

LAYOUT_FILE = "foxglove_layout.json"
SHIPPED = Path(__file__).with_name(LAYOUT_FILE)
FRAME_ID = "insar_track"
MARKERS = "/formation/markers"
FLOWN_MARKERS = "/formation/markers/flown"
FORMATION = "/formation"
DIAGNOSTICS = "/diagnostics"
OFFLOAD_POWER_INDEX = 1  # ("slot", "power_w", "energy_used_j", "energy_left_j")


def achieved_rate_path(k: int) -> str:
    return f"/{uav_name(k)}/achieved_rate.data"


def power_path(k: int) -> str:
    return f"/{uav_name(k)}/offload.data[{OFFLOAD_POWER_INDEX}]"


def position_error_path(k: int) -> str:
    return (f'{DIAGNOSTICS}.status[:]{{name=="{uav_status_name(k)}"}}'
            f'.values[:]{{key=="{POSITION_ERROR_KEY}"}}.value')


def _plot(title: str, paths: list[tuple[str, str]]) -> dict[str, Any]:
    return {"title": title,
            "paths": [{"value": value, "label": label, "enabled": True,
                       "timestampMethod": "receiveTime"} for value, label in paths],
            "showXAxisLabels": True, "showYAxisLabels": True, "showLegend": True,
            "legendDisplay": "floating", "showPlotValuesInLegend": True, "isSynced": True,
            "xAxisVal": "timestamp", "sidebarDimension": 240}


def _three_d() -> dict[str, Any]:
    # Looking across the Table I scene (track y 0..344 m, formation x -36..47 m, z ~50 m);
    # the camera is only where the view starts.
    camera = {"perspective": True, "distance": 450.0, "phi": 60.0, "thetaOffset": 45.0,
              "targetOffset": [20.0, 170.0, 0.0], "target": [0.0, 0.0, 0.0],
              "targetOrientation": [0.0, 0.0, 0.0, 1.0], "fovy": 45.0, "near": 0.5,
              "far": 5000.0}
    return {"cameraState": camera, "followMode": "follow-pose", "followTf": FRAME_ID,
            "scene": {}, "transforms": {}, "layers": {},
            "topics": {MARKERS: {"visible": True}, FLOWN_MARKERS: {"visible": True}}}


def _split(first: Any, second: Any, direction: str, percent: float) -> dict[str, Any]:
    return {"first": first, "second": second, "direction": direction,
            "splitPercentage": percent}


def foxglove_layout(num_uavs: int = DEFAULT_NUM_UAVS) -> dict[str, Any]:
    """The layout (see the module docstring) for UAVs uav0..uav(num_uavs-1); ValueError (one
    line) for a count that is no swarm's."""
    if problem := count_problem("num_uavs", num_uavs):
        raise ValueError(problem)
    swarm = uavs(num_uavs)
    config = {
        "3D!markers": _three_d(),
        "Plot!rate": _plot("achieved rate [bit/s]",
                           [(achieved_rate_path(k), uav_name(k)) for k in swarm]),
        "Plot!power": _plot("power applied [W]",
                            [(power_path(k), uav_name(k)) for k in swarm]),
        "Plot!position_error": _plot("position error [m] (planner)",
                                     [(position_error_path(k), uav_name(k)) for k in swarm]),
        "DiagnosticSummary!all": {"minLevel": 0, "pinnedIds": [], "hardwareIdFilter": "",
                                  "topicToRender": DIAGNOSTICS, "sortByLevel": True},
        "DiagnosticStatusPanel!plan": {"topicToRender": DIAGNOSTICS,
                                       "selectedHardwareId": HARDWARE_ID,
                                       "selectedName": PLAN_STATUS_NAME},
        "RawMessages!formation": {"topicPath": FORMATION, "diffEnabled": False,
                                  "diffMethod": "custom", "diffTopicPath": "",
                                  "showFullMessageForDiff": False},
    }
    plots = _split("Plot!rate", _split("Plot!power", "Plot!position_error", "column", 50.0),
                   "column", 33.3)
    bottom = _split("DiagnosticSummary!all",
                    _split("DiagnosticStatusPanel!plan", "RawMessages!formation", "row", 50.0),
                    "row", 33.3)
    layout = _split(_split("3D!markers", plots, "row", 55.0), bottom, "column", 70.0)
    return {"configById": config, "globalVariables": {}, "userNodes": {},
            "playbackConfig": {"speed": 1.0}, "layout": layout}


def layout_json(num_uavs: int = DEFAULT_NUM_UAVS) -> str:
    """`foxglove_layout(num_uavs)` as a file's text (the default's is SHIPPED's)."""
    return json.dumps(foxglove_layout(num_uavs), indent=2) + "\n"


if __name__ == "__main__":
    SHIPPED.write_text(layout_json())
    print(f"wrote {SHIPPED}")
