"""What the simulated vehicle does differently per autopilot flavour: one `VehicleProfile` a
flavour, in `VEHICLE_PROFILES`, beside the bridge's `AutopilotProfile` of the same name.

Adding a flavour the simulator flies is a row here (its modes must be ones `autopilot.py`
flies); `vehicle_profile(name)` is the one place that looks a flavour up by its name. Modes are
named as in the planner's tables (`COPTER_MODES`, `PX4_MODES`); a mode's own behaviour (GUIDED,
OFFBOARD, TAKEOFF, ...) is keyed by its name in `autopilot.py`, not by the flavour.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from uav_insar_planner.autopilots.profiles import (
    COPTER_MODES,
    AutopilotProfile,
    copter_mode_name,
    profile,
    px4_custom_mode,
    px4_mode_name,
)
from uav_insar_planner.mavlink.link import MAV
from uav_insar_sim.vehicle.parameters import Param, copter_params, px4_params


@dataclass(frozen=True)
class VehicleProfile:
    """One flavour of the simulated multicopter (see the module doc)."""

    #: the bridge's view: the mode it flies in, ..., its MAV_AUTOPILOT (HEARTBEAT.autopilot)
    autopilot: AutopilotProfile
    #: mode name -> HEARTBEAT.custom_mode, and (custom_mode, main, sub) -> mode name or None
    custom_mode: Callable[[str], int]
    mode_named: Callable[[int, int, int], str | None]
    ground_mode: str  # the mode a vehicle on the ground boots in
    #: a mode set while booting falls back to this one when boot ends (None: it sticks)
    boot_fallback_mode: str | None
    refuses_while_booting: bool  # mode changes and RTL: TEMPORARILY_REJECTED until booted
    #: a mode change starts a new session without a target; the same mode again is a no-op
    mode_change_clears_target: bool
    unknown_mode: int  # MAV_RESULT for a mode it does not have
    refused: int  # MAV_RESULT of a flight refusal (arm, disarm in flight, takeoff)
    boot_arm_refusal: int  # MAV_RESULT of arming while the estimator boots
    prearm_text: str  # the STATUSTEXT that says why
    not_armable_modes: frozenset[str]
    frames: frozenset[int]  # MAV_FRAMEs of the setpoints it takes
    heartbeat_flags: int  # MAV_MODE_FLAGs beyond custom mode and armed
    boot_state: int  # MAV_STATE while booting
    rtl_alt_m: float  # RTL_ALT / RTL_RETURN_ALT default
    #: NAV_TAKEOFF enters this mode and takes param 7 AMSL, NaN or < 0.5 m above home for
    #: the default height; None: only in the flight mode on the ground, param 7 > 0 m above
    #: home
    takeoff_mode: str | None
    #: MISSION_START from any stored item (PX4's commander); else from the first only
    mission_start_from_item: bool
    version: tuple[int, int, int, int]  # (major, minor, patch, FIRMWARE_VERSION_TYPE)
    bytewise_params: bool  # PARAM_ENCODE_BYTEWISE (else C_CAST)
    params: Callable[[object], list[Param]]  # the parameter list of a SimVehicle


VEHICLE_PROFILES = {
    "ardupilot": VehicleProfile(
        profile("ardupilot"), custom_mode=COPTER_MODES.__getitem__,
        mode_named=lambda custom, main, sub: copter_mode_name(custom),
        ground_mode="STABILIZE", boot_fallback_mode="STABILIZE", refuses_while_booting=False,
        mode_change_clears_target=True, unknown_mode=MAV.MAV_RESULT_FAILED,
        refused=MAV.MAV_RESULT_FAILED, boot_arm_refusal=MAV.MAV_RESULT_FAILED,
        prearm_text="PreArm: AHRS: waiting for home",
        not_armable_modes=frozenset(("RTL", "LAND", "BRAKE")),
        frames=frozenset((MAV.MAV_FRAME_LOCAL_NED, MAV.MAV_FRAME_LOCAL_OFFSET_NED,
                          MAV.MAV_FRAME_BODY_NED, MAV.MAV_FRAME_BODY_OFFSET_NED)),
        heartbeat_flags=MAV.MAV_MODE_FLAG_STABILIZE_ENABLED,
        boot_state=MAV.MAV_STATE_CALIBRATING, rtl_alt_m=15.0, takeoff_mode=None,
        mission_start_from_item=False, version=(4, 7, 0, MAV.FIRMWARE_VERSION_TYPE_DEV),
        bytewise_params=False, params=copter_params),
    "px4": VehicleProfile(
        profile("px4"), custom_mode=px4_custom_mode,
        mode_named=lambda custom, main, sub: px4_mode_name(main, sub),
        ground_mode="POSCTL", boot_fallback_mode=None, refuses_while_booting=True,
        mode_change_clears_target=False, unknown_mode=MAV.MAV_RESULT_UNSUPPORTED,
        refused=MAV.MAV_RESULT_DENIED, boot_arm_refusal=MAV.MAV_RESULT_TEMPORARILY_REJECTED,
        prearm_text="Preflight Fail: No valid global position estimate",
        not_armable_modes=frozenset(),
        frames=frozenset((MAV.MAV_FRAME_LOCAL_NED, MAV.MAV_FRAME_BODY_NED)),
        heartbeat_flags=0, boot_state=MAV.MAV_STATE_BOOT, rtl_alt_m=60.0,
        takeoff_mode="TAKEOFF", mission_start_from_item=True,
        version=(1, 15, 0, MAV.FIRMWARE_VERSION_TYPE_OFFICIAL), bytewise_params=True,
        params=px4_params),
}
SIMULATED = tuple(VEHICLE_PROFILES)  # the --autopilot choices of `uav-insar-vehicle`


def vehicle_profile(name: str) -> VehicleProfile:
    """The profile of flavour `name`; ValueError naming the simulated ones otherwise."""
    if name not in VEHICLE_PROFILES:
        raise ValueError(f"autopilot: {name!r:.40} is not allowed; expected one of "
                         f"{', '.join(SIMULATED)}")
    return VEHICLE_PROFILES[name]
