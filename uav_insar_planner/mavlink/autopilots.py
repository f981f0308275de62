"""What the bridge and the simulated vehicle both know about the two autopilots.

`AUTOPILOTS` names the flavours accepted everywhere. Mode numbers are the ones each autopilot
puts in HEARTBEAT.custom_mode: ArduCopter uses the plain mode number (`COPTER_MODES`), PX4
packs main and sub mode as main << 16 | sub << 24 (`PX4_MODES`, `px4_custom_mode`).

Only the modes the simulator flies are listed (a GCS's usual ones). PX4 names: "HOLD" is
AUTO.LOITER, "TAKEOFF" AUTO.TAKEOFF, "LAND" AUTO.LAND, "RTL" AUTO.RTL.
"""
from __future__ import annotations

# The choices of the bridge's `autopilot` parameter, kept with the parameter tables.
from uav_insar_planner.param_specs.nodes import AUTOPILOTS as AUTOPILOTS

#: ArduCopter mode numbers (ArduCopter's `Mode::Number`).
COPTER_MODES = {"STABILIZE": 0, "ALT_HOLD": 2, "GUIDED": 4, "LOITER": 5, "RTL": 6, "LAND": 9,
                "BRAKE": 17}
#: PX4 (main mode, sub mode); sub mode 0 for main modes other than AUTO (4).
PX4_MODES = {"MANUAL": (1, 0), "ALTCTL": (2, 0), "POSCTL": (3, 0), "OFFBOARD": (6, 0),
             "TAKEOFF": (4, 2), "HOLD": (4, 3), "RTL": (4, 5), "LAND": (4, 6)}
#: PX4's main mode AUTO, the only one whose sub mode matters.
PX4_MAIN_MODE_AUTO = 4
#: The bits of custom_mode that hold PX4's main mode.
PX4_MAIN_MODE_MASK = 0x00FF0000


def px4_custom_mode(name: str) -> int:
    """PX4 mode name (a key of PX4_MODES) -> HEARTBEAT.custom_mode."""
    main, sub = PX4_MODES[name]
    return (main << 16) | (sub << 24)


def px4_mode_name(main: int, sub: int) -> str | None:
    """(main, sub) -> the PX4_MODES name, or None when the simulator has no such mode."""
    for name, (m, s) in PX4_MODES.items():
        if m == main and (s == sub or m != PX4_MAIN_MODE_AUTO):
            return name
    return None


def copter_mode_name(number: int) -> str | None:
    """ArduCopter mode number -> the COPTER_MODES name, or None when not simulated."""
    for name, n in COPTER_MODES.items():
        if n == number:
            return name
    return None
