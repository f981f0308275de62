"""A QGroundControl `.plan` read back as the MAVLink mission a vehicle is sent: what `uav-insar
upload-mission` (cli/upload_mission.py) uploads, checked where it enters (no MAVLink link).

`read_plan(path, name)` returns a `PlanMission`, or raises ParamError with one line naming the
file, the field, its value and what is allowed. Accepted: `fileType` "Plan",
`mission.firmwareType` a flavour's MAV_AUTOPILOT (autopilots/profiles.py: 12 PX4, 3
ArduPilot), `mission.plannedHomePosition` [lat, lon, alt], 1..MAX_ITEMS `mission.items`,
each a `SimpleItem` (QGroundControl's complex items, surveys and corridor scans, are refused:
`uav-insar export-mission` and `survey` write simple items only) with `command` 0..65535,
`frame` one of FRAMES, `autoContinue` true or false and seven `params`, numbers or null. A
position item (a global frame) needs a finite latitude within +-90 deg, longitude within +-180
deg and altitude within +-ALT_MAX_M. The items are as `qgc_plan` writes them and as MAVSDK's
`import_qgroundcontrol_mission` reads them:
- a null param is NaN (p1..p4) or 0 (x, y, z);
- a position item's latitude and longitude become MISSION_ITEM_INT's x, y in 1e-7 degrees,
  a MAV_FRAME_MISSION item's x, y are its params 5 and 6 as integers;
- where the flavour's missions begin with the home (`mission_home_item`: ArduPilot, which
  overwrites seq 0 with its own), `plannedHomePosition` is sent first as a
  MAV_CMD_NAV_WAYPOINT in MAV_FRAME_GLOBAL; PX4's have no home item, so the file's first item
  is seq 0 (`qgc_plan.PX4_PASS_SEQ`).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

from uav_insar_planner.autopilots.profiles import PROFILES, by_mav_autopilot
from uav_insar_planner.params import ParamError, shown

#: MAV_FRAME values an item may have: GLOBAL, MISSION, GLOBAL_RELATIVE_ALT, GLOBAL_INT,
#: GLOBAL_RELATIVE_ALT_INT, GLOBAL_TERRAIN_ALT, GLOBAL_TERRAIN_ALT_INT
FRAMES = (0, 2, 3, 5, 6, 10, 11)
FRAME_MISSION = 2
MAX_ITEMS = 1000
MAX_FILE_BYTES = 10_000_000
ALT_MAX_M = 1.0e5
CMD_WAYPOINT = 16


@dataclass(frozen=True)
class MissionItem:
    """One MISSION_ITEM_INT's fields (no target, no `current`)."""

    seq: int
    frame: int
    command: int
    params: tuple[float, float, float, float]
    x: int
    y: int
    z: float
    autocontinue: int


@dataclass(frozen=True)
class PlanMission:
    """A `.plan` as its vehicle is sent it: `firmware` (a MAV_AUTOPILOT), the items in order
    (ArduPilot's home first), and whether seq 0 is that home."""

    firmware: int
    items: tuple[MissionItem, ...]
    home_item: bool

    @property
    def autopilot(self) -> str:
        """The flavour's name (autopilots/profiles.py)."""
        return by_mav_autopilot(self.firmware).name


def _bad(where: str, value: object, expected: str) -> ParamError:
    return ParamError([f"{where}: value {shown(value)} is not allowed; expected {expected}"])


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _load(path: Path, name: str) -> dict:
    try:
        if path.stat().st_size > MAX_FILE_BYTES:
            raise _bad(name, str(path), f"a .plan file under {MAX_FILE_BYTES} bytes")
        doc = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise _bad(name, str(path), f"a readable .plan file ({exc.strerror})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _bad(name, str(path), f"a QGroundControl .plan (JSON): {exc}") from None
    if not isinstance(doc, dict) or doc.get("fileType") != "Plan":
        got = doc.get("fileType") if isinstance(doc, dict) else type(doc).__name__
        raise _bad(f"{name} fileType", got, "'Plan' (a QGroundControl .plan)")
    if not isinstance(doc.get("mission"), dict):
        raise _bad(f"{name} mission", doc.get("mission"), "an object with items")
    return doc["mission"]


def _position(where: str, lat: object, lon: object, alt: object) -> tuple[int, int, float]:
    if not (_number(lat) and math.isfinite(lat) and abs(lat) <= 90.0):
        raise _bad(f"{where} latitude", lat, "a finite number within +-90 degrees")
    if not (_number(lon) and math.isfinite(lon) and abs(lon) <= 180.0):
        raise _bad(f"{where} longitude", lon, "a finite number within +-180 degrees")
    if not (_number(alt) and math.isfinite(alt) and abs(alt) <= ALT_MAX_M):
        raise _bad(f"{where} altitude", alt, f"a finite number within +-{ALT_MAX_M:g} m")
    return round(lat * 1e7), round(lon * 1e7), float(alt)


def _item(where: str, seq: int, raw: object) -> MissionItem:
    if not isinstance(raw, dict) or raw.get("type") != "SimpleItem":
        got = raw.get("type") if isinstance(raw, dict) else raw
        raise _bad(f"{where} type", got, "'SimpleItem' (complex items such as surveys are not "
                   "uploaded; export-mission and survey write simple items)")
    command, frame, params = raw.get("command"), raw.get("frame"), raw.get("params")
    if not (isinstance(command, int) and not isinstance(command, bool)
            and 0 <= command <= 65535):
        raise _bad(f"{where} command", command, "a MAV_CMD, an integer in 0..65535")
    if frame not in FRAMES or isinstance(frame, bool):
        raise _bad(f"{where} frame", frame, f"a MAV_FRAME of {list(FRAMES)}")
    if not isinstance(raw.get("autoContinue", True), bool):
        raise _bad(f"{where} autoContinue", raw.get("autoContinue"), "true or false")
    if not (isinstance(params, list) and len(params) == 7
            and all(p is None or (_number(p) and not math.isinf(p)) for p in params)):
        raise _bad(f"{where} params", params, "seven numbers or nulls")
    p = [math.nan if v is None else float(v) for v in params]
    if frame == FRAME_MISSION:
        if any(not (math.isnan(v) or abs(v) < 2**31) for v in p[4:6]):
            raise _bad(f"{where} params", params, "params 5 and 6 within the int32 range")
        x, y = (0 if math.isnan(v) else int(v) for v in p[4:6])
        z = 0.0 if math.isnan(p[6]) else p[6]
    else:
        x, y, z = _position(where, *params[4:7])
    return MissionItem(seq, frame, command, (p[0], p[1], p[2], p[3]), x, y, z,
                       int(raw.get("autoContinue", True)))


def read_plan(path: Path, name: str) -> PlanMission:
    """The mission of the `.plan` at `path` (`name` says which argument it is in errors)."""
    mission = _load(path, name)
    firmware = mission.get("firmwareType")
    flavour = by_mav_autopilot(firmware)
    if flavour is None:
        raise _bad(f"{name} mission.firmwareType", firmware, " or ".join(
            f"{p.mav_autopilot} ({p.name})" for p in PROFILES.values()))
    items = mission.get("items")
    if not isinstance(items, list) or not 1 <= len(items) <= MAX_ITEMS:
        raise _bad(f"{name} mission.items", items if not isinstance(items, list)
                   else f"{len(items)} items", f"a list of 1..{MAX_ITEMS} items")
    home = mission.get("plannedHomePosition")
    if not isinstance(home, list) or len(home) != 3:
        raise _bad(f"{name} mission.plannedHomePosition", home, "[latitude, longitude, "
                   "altitude AMSL]")
    home_xyz = _position(f"{name} mission.plannedHomePosition", *home)
    out = [MissionItem(0, 0, CMD_WAYPOINT, (0.0, 0.0, 0.0, 0.0), *home_xyz, 1)] \
        if flavour.mission_home_item else []
    for i, raw in enumerate(items):
        out.append(_item(f"{name} mission.items[{i}]", len(out), raw))
    return PlanMission(firmware, tuple(out), flavour.mission_home_item)
