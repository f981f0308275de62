"""One QGroundControl `.plan` file per UAV: the pass flown by the autopilot on its own.

The items, in order (MAVLink mission; `frame` 0 = MAV_FRAME_GLOBAL, AMSL heights, or 3 =
MAV_FRAME_GLOBAL_RELATIVE_ALT for the positions (`ALTITUDE_FRAMES`), 2 = MAV_FRAME_MISSION for
the others, as QGroundControl writes them):

1. MAV_CMD_NAV_TAKEOFF to z_k (its coordinate is the pass start: ArduCopter climbs where it
   stands, PX4 climbs and then flies there);
2. MAV_CMD_NAV_WAYPOINT at the pass start (x_k, -run_up, z_k): the run-up lets the vehicle
   reach v_y before y = 0 (`run_up_m`, default RUN_UP_S of v_y);
3. the wait for the common start:
   - ArduPilot: MAV_CMD_NAV_DELAY with param1 = -1 and param2..4 = hour, minute, second UTC:
     every UAV waits at its start until that time on its own (GNSS-synced) clock, so the
     passes start together without a link between them; a vehicle that arrives after that
     time waits for it on the next day, so the time must leave room for take-off and transit;
   - PX4: MAV_CMD_NAV_LOITER_UNLIM at the pass start. PX4 keeps only NAV_DELAY's param1 (a
     hold time, clamped to 0) and ignores the UTC fields, so each UAV holds there until
     MAV_CMD_MISSION_START with first item PX4_PASS_SEQ (`uav-insar start-missions`) moves it
     on, at one instant for all;
4. MAV_CMD_DO_CHANGE_SPEED (ground speed) to v_y, then MAV_CMD_NAV_WAYPOINT at the pass end
   y = num_slots * slot_duration_s * v_y;
5. MAV_CMD_NAV_LOITER_UNLIM at the pass end (`end="hold"`) or MAV_CMD_NAV_RETURN_TO_LAUNCH
   (`end="rtl"`).

Heights: "amsl" (the default) writes home.alt_m + z_k in MAV_FRAME_GLOBAL, so every UAV flies
z_k above the track origin wherever it was armed, given that its AMSL altitude is as good as
the baselines need. "relative" writes z_k above each UAV's own home (where it armed): right
only when every UAV arms on ground at the origin's altitude (docs/hardware.md).

Unused params: null where QGroundControl writes NaN (the waypoints' yaw), 0 where it writes 0
(the coordinate of an item without one: its `_setDefaultsForCommand`).

Track frame (x across-track, y along-track, z up) -> local NED about the home with
`track.frame.TrackFrame` (bearing of y from north), NED -> latitude / longitude with
`geodesy` (tangent-plane approximation; its error bound is there). The file format is
QGroundControl's (`fileType` Plan, version 1; mission version 2), as MAVSDK's
`mission_raw.import_qgroundcontrol_mission` reads it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timedelta

from uav_insar_planner.autopilots.profiles import profile
from uav_insar_planner.mission_file.geodesy import ned_to_latlon
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.passes import TrackPass

VEHICLE_TYPE = 2  # MAV_TYPE_QUADROTOR
ENDS = ("hold", "rtl")
FRAME_GLOBAL, FRAME_MISSION, FRAME_RELATIVE_ALT = 0, 2, 3
#: height frame -> (MAV_FRAME, QGroundControl's AltitudeMode: 1 relative, 2 absolute)
ALTITUDE_FRAMES = {"amsl": (FRAME_GLOBAL, 2), "relative": (FRAME_RELATIVE_ALT, 1)}
#: Where a PX4 file's pass begins: the mission sequence number of its DO_CHANGE_SPEED (PX4
#: missions have no home item, so the .plan's first item is seq 0), MISSION_START's param1.
PX4_PASS_SEQ = 3
CMD_WAYPOINT, CMD_LOITER_UNLIM, CMD_RTL, CMD_TAKEOFF = 16, 17, 20, 22
CMD_DELAY, CMD_CHANGE_SPEED = 93, 178
RUN_UP_S = 3.0  # ArduCopter's jerk-limited start (WPNAV_ACCEL 2.5 m/s^2) needs ~2.5 s to 5 m/s
# The default start time (default_start): time to upload, arm and switch to AUTO, then a
# climb and a transit slower than the autopilots' defaults (ArduCopter 2.5 m/s up, 10 m/s
# across; PX4 3 m/s, 5 m/s), then time to settle at the start point.
PREFLIGHT_S = 120.0
CLIMB_MPS = 1.0
TRANSIT_MPS = 2.0
SETTLE_S = 20.0
# The least lead of a given start time (`--start-utc`): a minute to upload, arm and fly to the
# starts is already tight (default_start allows PREFLIGHT_S and the climb); an ArduPilot UAV
# that reaches its start after the time waits for it on the next day.
START_LEAD_MIN_S = 60.0


@dataclass(frozen=True)
class Home:
    """The track origin (x = y = 0 on the ground): latitude, longitude [deg], AMSL [m]."""

    lat_deg: float
    lon_deg: float
    alt_m: float


@dataclass(frozen=True)
class Pass:
    """What every UAV flies: the along-track speed v_y [m/s], the pass length [m] and the
    run-up before y = 0 [m]; `bearing_deg` points y (from north, clockwise)."""

    speed_mps: float
    length_m: float
    run_up_m: float
    bearing_deg: float


def track_to_latlon(home: Home, bearing_deg: float, x: float, y: float) -> tuple[float, float]:
    """The latitude and longitude of the ground point (x, y) of the track frame."""
    n, e, _ = TrackFrame.from_degrees(bearing_deg).to_ned(x, y, 0.0)
    return ned_to_latlon(home.lat_deg, home.lon_deg, n, e)


def default_start(now: datetime, xz: dict[int, tuple[float, float]], run_up_m: float
                  ) -> datetime:
    """The start time when none is given: `now` + PREFLIGHT_S + the slowest UAV's climb to
    z_k at CLIMB_MPS and transit to its start point at TRANSIT_MPS + SETTLE_S, rounded up to
    the next whole second (NAV_DELAY has whole seconds)."""
    fly = max(z / CLIMB_MPS + math.hypot(x, run_up_m) / TRANSIT_MPS for x, z in xz.values())
    t = now + timedelta(seconds=PREFLIGHT_S + fly + SETTLE_S)
    return t.replace(microsecond=0) + timedelta(seconds=1 if t.microsecond else 0)


def mission_item(seq: int, command: int, params: list[float], frame: str | None) -> dict:
    """One QGroundControl SimpleItem: a position item in the height `frame` (ALTITUDE_FRAMES),
    or with `frame` None a MAV_FRAME_MISSION one; NaN params become null."""
    item = {"type": "SimpleItem", "command": command,
            "frame": FRAME_MISSION if frame is None else ALTITUDE_FRAMES[frame][0],
            "params": [None if math.isnan(p) else p for p in params],
            "autoContinue": True, "doJumpId": seq}
    if frame is not None:
        item |= {"AMSLAltAboveTerrain": None, "Altitude": params[6],
                 "AltitudeMode": ALTITUDE_FRAMES[frame][1]}
    return item


def mission_items(home: Home, flight: Pass, x: float, z: float, start: datetime | None,
                  end: str, frame: str = "amsl") -> list[dict]:
    """The `.plan` items of the UAV flying across-track position x at height z above the
    track origin; `start` is the NAV_DELAY time (ArduPilot), None for PX4's hold."""
    nan = math.nan
    alt = z + home.alt_m if frame == "amsl" else z
    line = TrackPass(x, 0.0, flight.length_m, run_in_m=flight.run_up_m)
    begin = (*track_to_latlon(home, flight.bearing_deg, *line.entry), alt)
    finish = (*track_to_latlon(home, flight.bearing_deg, *line.point(flight.length_m)), alt)
    # yaw 0 on the loiters, not NaN: ArduPilot refuses a NaN param4 on every command but a few
    wait = ((CMD_LOITER_UNLIM, [0.0, 0.0, 0.0, 0.0, *begin], frame) if start is None else
            (CMD_DELAY, [-1.0, start.hour, start.minute, start.second, 0.0, 0.0, 0.0], None))
    items = [(CMD_TAKEOFF, [0.0, 0.0, 0.0, nan, *begin], frame),
             (CMD_WAYPOINT, [0.0, 0.0, 0.0, nan, *begin], frame), wait,
             (CMD_CHANGE_SPEED, [1.0, flight.speed_mps, -1.0, 0.0, 0.0, 0.0, 0.0], None),
             (CMD_WAYPOINT, [0.0, 0.0, 0.0, nan, *finish], frame)]
    if end == "hold":
        items.append((CMD_LOITER_UNLIM, [0.0, 0.0, 0.0, 0.0, *finish], frame))
    else:
        items.append((CMD_RTL, [0.0] * 7, None))
    return [mission_item(i + 1, cmd, [float(p) for p in params], f)
            for i, (cmd, params, f) in enumerate(items)]


def plan_document(home: Home, flight: Pass, x: float, z: float, start: datetime | None,
                  end: str, autopilot: str, frame: str = "amsl") -> dict:
    """The whole `.plan` JSON object of one UAV (geofence and rally points empty); `start`
    is ignored where the autopilot holds for MISSION_START (PX4: no NAV_DELAY)."""
    flavour = profile(autopilot)
    start = start if flavour.mission_waits_for_utc else None
    if start is None and flavour.mission_waits_for_utc:
        raise ValueError(f"start: None; an {autopilot} file waits for a UTC time (NAV_DELAY)")
    return plan_json(home, mission_items(home, flight, x, z, start, end, frame),
                     flight.speed_mps, autopilot, frame)


def plan_json(home: Home, items: list[dict], speed_mps: float, autopilot: str,
              frame: str) -> dict:
    """The whole `.plan` JSON object around mission `items` (geofence and rally points
    empty)."""
    return {"fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
            "mission": {"version": 2, "firmwareType": profile(autopilot).mav_autopilot,
                        "vehicleType": VEHICLE_TYPE, "cruiseSpeed": speed_mps,
                        "hoverSpeed": speed_mps,
                        "globalPlanAltitudeMode": ALTITUDE_FRAMES[frame][1],
                        "plannedHomePosition": [home.lat_deg, home.lon_deg, home.alt_m],
                        "items": items},
            "geoFence": {"version": 2, "circles": [], "polygons": []},
            "rallyPoints": {"version": 2, "points": []}}
