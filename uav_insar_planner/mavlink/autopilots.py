"""What the bridge and the simulated vehicle both know about the two autopilots.

`AUTOPILOTS` names the flavours accepted everywhere. Mode numbers are the ones each autopilot
puts in HEARTBEAT.custom_mode: ArduCopter uses the plain mode number (`COPTER_MODES`), PX4
packs main and sub mode as main << 16 | sub << 24 (`PX4_MODES`, `px4_custom_mode`).
"""
from __future__ import annotations

AUTOPILOTS = ("ardupilot", "px4")
COPTER_MODES = {"STABILIZE": 0, "GUIDED": 4, "LOITER": 5, "LAND": 9}
PX4_MODES = {"POSCTL": (3, 0), "OFFBOARD": (6, 0), "TAKEOFF": (4, 2), "HOLD": (4, 3),
             "LAND": (4, 6)}
#: The bits of custom_mode that hold PX4's main mode.
PX4_MAIN_MODE_MASK = 0x00FF0000


def px4_custom_mode(name: str) -> int:
    """PX4 mode name (a key of PX4_MODES) -> HEARTBEAT.custom_mode."""
    main, sub = PX4_MODES[name]
    return (main << 16) | (sub << 24)
