"""One QGroundControl `.plan` per UAV per sortie of a survey: its strips flown by the autopilot
on its own, one after the other, as `qgc_plan` flies the one pass.

The items, in order (heights as `qgc_plan.ALTITUDE_FRAMES`, AMSL by default):

1. MAV_CMD_NAV_TAKEOFF to z_k (its coordinate is the first strip's entry);
2. for each strip j of the sortie:
   - MAV_CMD_DO_CHANGE_SPEED to the transit speed, MAV_CMD_NAV_WAYPOINT at the UAV's entry of
     strip j: (x_k, -run_in, z_k) in the strip's formation frame (the turn from the strip
     before, or the transit from home);
   - the wait for the strip's common start, as for the one pass: ArduPilot MAV_CMD_NAV_DELAY
     until strip j's UTC start; PX4 MAV_CMD_NAV_LOITER_UNLIM there, left by
     `uav-insar start-missions --item <seq>` with the sequence number `pass_items` gives;
   - MAV_CMD_DO_CHANGE_SPEED to v_y and MAV_CMD_NAV_WAYPOINT at (x_k, L_j, z_k), the end of
     its imaged part: the run-in brings the vehicle to v_y before slot 0's line;
3. MAV_CMD_NAV_RETURN_TO_LAUNCH: a sortie ends landed at home, for the next battery.

Each strip's formation frame (`StripLeg.frame`, track.frame.TrackFrame about home) turns with
the strip's direction, so the slaves stay on the look side of a strip flown the other way.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime

from uav_insar_planner.autopilots.profiles import profile
from uav_insar_planner.mission_file.geodesy import ned_to_latlon
from uav_insar_planner.mission_file.qgc_plan import (
    CMD_CHANGE_SPEED,
    CMD_DELAY,
    CMD_LOITER_UNLIM,
    CMD_RTL,
    CMD_TAKEOFF,
    CMD_WAYPOINT,
    Home,
    mission_item,
    plan_json,
)
from uav_insar_planner.track.frame import TrackFrame


@dataclass(frozen=True)
class StripLeg:
    """One strip as a UAV's mission flies it: its formation frame, the length of its imaged
    part and its run-in [m], and its UTC start (None: the autopilot holds for
    MISSION_START)."""

    frame: TrackFrame
    length_m: float
    run_in_m: float
    start: datetime | None


def _position(home: Home, frame: TrackFrame, x: float, y: float, alt: float) -> list[float]:
    n, e, _ = frame.to_ned(x, y, 0.0)
    return [*ned_to_latlon(home.lat_deg, home.lon_deg, n, e), alt]


def sortie_items(home: Home, legs: Sequence[StripLeg], x: float, z: float, speed_mps: float,
                 transit_mps: float, frame: str = "amsl") -> tuple[list[dict], list[int]]:
    """(the `.plan` items of the UAV at (x, z) of the formation flying `legs`, the sequence
    number of each strip's DO_CHANGE_SPEED to v_y: where MISSION_START resumes it)."""
    nan = math.nan
    alt = z + home.alt_m if frame == "amsl" else z
    first = legs[0]
    raw: list[tuple[int, list[float], str | None]] = [
        (CMD_TAKEOFF, [0.0, 0.0, 0.0, nan, *_position(home, first.frame, x, -first.run_in_m,
                                                      alt)], frame)]
    pass_seqs = []
    for leg in legs:
        entry = _position(home, leg.frame, x, -leg.run_in_m, alt)
        finish = _position(home, leg.frame, x, leg.length_m, alt)
        # yaw 0 on the loiter, not NaN: ArduPilot refuses a NaN param4 on most commands
        wait = ((CMD_LOITER_UNLIM, [0.0, 0.0, 0.0, 0.0, *entry], frame) if leg.start is None
                else (CMD_DELAY, [-1.0, leg.start.hour, leg.start.minute, leg.start.second,
                                  0.0, 0.0, 0.0], None))
        raw += [(CMD_CHANGE_SPEED, [1.0, transit_mps, -1.0, 0.0, 0.0, 0.0, 0.0], None),
                (CMD_WAYPOINT, [0.0, 0.0, 0.0, nan, *entry], frame), wait]
        pass_seqs.append(len(raw))  # (PX4 has no home item: the first item is its seq 0)
        raw += [(CMD_CHANGE_SPEED, [1.0, speed_mps, -1.0, 0.0, 0.0, 0.0, 0.0], None),
                (CMD_WAYPOINT, [0.0, 0.0, 0.0, nan, *finish], frame)]
    raw.append((CMD_RTL, [0.0] * 7, None))
    items = [mission_item(i + 1, cmd, [float(p) for p in params], f)
             for i, (cmd, params, f) in enumerate(raw)]
    return items, pass_seqs


def sortie_document(home: Home, legs: Sequence[StripLeg], x: float, z: float,
                    speed_mps: float, transit_mps: float, autopilot: str,
                    frame: str = "amsl") -> dict:
    """The whole `.plan` JSON object of one UAV for one sortie; every leg must carry a UTC
    start where the autopilot waits for one (ArduPilot), none where it holds (PX4)."""
    waits = profile(autopilot).mission_waits_for_utc
    if any((leg.start is None) == waits for leg in legs):
        raise ValueError(f"start: an {autopilot} file " + (
            "waits for a UTC time at each strip (NAV_DELAY)" if waits else
            "holds at each strip for MISSION_START, with no UTC time"))
    items, _ = sortie_items(home, legs, x, z, speed_mps, transit_mps, frame)
    return plan_json(home, items, speed_mps, autopilot, frame)
