"""COMMAND_LONG / COMMAND_INT handling of the simulated vehicle: parameters checked first.

`run_command(vehicle, command, params, now)` returns (the MAV_RESULT to ACK, the problem with
the parameters or ""; the vehicle counts those as bad values). `params` are the
seven command parameters (COMMAND_INT's x, y arrive as numbers, z as param 7). A NaN
parameter means "unused": it takes its default where the command has one, and a required
parameter that is NaN, or any parameter that is infinite, out of range or not an integer
where one is needed, gets DENIED (ArduPilot-like flight refusals stay FAILED). Nothing a
ground station sends can raise.

Commands: COMPONENT_ARM_DISARM (force 21196), DO_SET_MODE, NAV_TAKEOFF (ArduPilot: param 7
metres above home; PX4: param 7 AMSL, NaN for MIS_TAKEOFF_ALT), NAV_LAND,
NAV_RETURN_TO_LAUNCH, SET_MESSAGE_INTERVAL, REQUEST_MESSAGE (512), GET_HOME_POSITION (410),
REQUEST_AUTOPILOT_CAPABILITIES (520), MISSION_START (300: recorded in `mission_starts` with
its UTC arrival, not flown; ACCEPTED as PX4's commander does, with a stored mission and
-1 <= first item < its count, else DENIED; as ArduCopter, DENIED with a first or last item,
FAILED without a mission); anything else is UNSUPPORTED.
"""
from __future__ import annotations

import math
import time
from collections.abc import Sequence

from uav_insar_planner.mavlink.link import MAV

FORCE_MAGIC = 21196
DENIED, FAILED = MAV.MAV_RESULT_DENIED, MAV.MAV_RESULT_FAILED
ACCEPTED, UNSUPPORTED = MAV.MAV_RESULT_ACCEPTED, MAV.MAV_RESULT_UNSUPPORTED


class BadParam(ValueError):
    """A command parameter that is required but NaN, infinite, out of range or not integral."""


def as_int(value: float, low: int, high: int, default: int | None = None,
           name: str = "param") -> int:
    """An integral parameter in [low, high]; NaN -> default; anything else raises BadParam."""
    if isinstance(value, float) and math.isnan(value):
        if default is None:
            raise BadParam(f"{name} is NaN, and it is required")
        return default
    if not math.isfinite(value) or value != round(value) or not low <= value <= high:
        raise BadParam(f"{name} = {value!r:.20} is not an integer in [{low}, {high}]")
    return int(value)


def run_command(vehicle, command: int, params: Sequence[float], now: float
                ) -> tuple[int, str]:
    """Dispatch one command to `vehicle` (a SimVehicle; its lock is held): (MAV_RESULT,
    problem with the parameters or "")."""
    try:
        return _dispatch(vehicle, command, [float(x) for x in params], now), ""
    except BadParam as exc:
        return DENIED, str(exc)


def _dispatch(vehicle, command: int, p: list[float], now: float) -> int:
    ap = vehicle._ap
    if command == MAV.MAV_CMD_COMPONENT_ARM_DISARM:
        arm = as_int(p[0], 0, 1, name="param1 (arm)")
        force = as_int(p[1], -2**31, 2**31, default=0, name="param2 (force)")
        return ap.arm(arm == 1, force == FORCE_MAGIC, now)
    if command == MAV.MAV_CMD_DO_SET_MODE:
        base = as_int(p[0], 0, 255, name="param1 (base mode)")
        custom = as_int(p[1], 0, 2**32 - 1, name="param2 (custom mode)")
        sub = as_int(p[2], 0, 255, default=0, name="param3 (sub mode)")
        if not base & MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return UNSUPPORTED
        return ap.set_mode(custom, custom, sub, now)
    if command == MAV.MAV_CMD_NAV_TAKEOFF:
        return _takeoff(vehicle, p[6], now)
    if command == MAV.MAV_CMD_MISSION_START:
        return _mission_start(vehicle, p)
    if command == MAV.MAV_CMD_NAV_LAND:
        return ap.land()
    if command == MAV.MAV_CMD_NAV_RETURN_TO_LAUNCH:
        return ap.rtl(now)
    if command == MAV.MAV_CMD_SET_MESSAGE_INTERVAL:
        msgid = as_int(p[0], 0, 2**24 - 1, name="param1 (message id)")
        if not math.isfinite(p[1]):
            raise BadParam(f"param2 (interval) = {p[1]!r} is not finite")
        if not vehicle.telemetry.can_build(msgid):
            return FAILED
        if not vehicle.streams.set_interval(msgid, p[1]):
            raise BadParam(f"param2 (interval) = {p[1]!r:.20} us; expected -1 (off), 0 "
                           "(default) or 1..1e8")
        return ACCEPTED
    if command in (MAV.MAV_CMD_REQUEST_MESSAGE, MAV.MAV_CMD_GET_HOME_POSITION,
                   MAV.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES):
        msgid = {MAV.MAV_CMD_GET_HOME_POSITION: MAV.MAVLINK_MSG_ID_HOME_POSITION,
                 MAV.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
                     MAV.MAVLINK_MSG_ID_AUTOPILOT_VERSION}.get(command)
        if msgid is None:
            msgid = as_int(p[0], 0, 2**24 - 1, name="param1 (message id)")
        if not vehicle.telemetry.can_build(msgid):
            return FAILED
        return ACCEPTED if vehicle.send_now(msgid, now) else FAILED
    return UNSUPPORTED


def _takeoff(vehicle, param7: float, now: float) -> int:
    ap = vehicle._ap
    if ap.profile.takeoff_mode is not None:  # param 7 AMSL (PX4)
        if math.isnan(param7):
            return ap.takeoff(float("nan"), now)
        if not math.isfinite(param7) or abs(param7) > 100000.0:
            raise BadParam(f"param7 (altitude) = {param7!r:.20} is not in [-1e5, 1e5] m")
        # PX4's param 7 is AMSL; the home's AMSL altitude is origin altitude - home D.
        home_amsl = vehicle.telemetry.origin[2] - float(ap.home[2])
        return ap.takeoff(param7 - home_amsl, now)
    if not math.isfinite(param7):
        raise BadParam(f"param7 (altitude) = {param7!r} is not finite")
    if not 0.0 < param7 < 10000.0:
        return ap.profile.refused
    return ap.takeoff(param7, now)


def _mission_start(vehicle, p: list[float]) -> int:
    first = as_int(p[0], -1, 65535, default=0, name="param1 (first item)")
    last = as_int(p[1], -1, 65535, default=0, name="param2 (last item)")
    count = len(vehicle.mission.items)
    if vehicle._ap.profile.mission_start_from_item:
        result = ACCEPTED if count and first < count else DENIED
    else:
        result = DENIED if first or last else ACCEPTED if count else FAILED
    vehicle.mission_starts.append((time.time(), first, result))
    return result
