"""What the bridge sends: SET_POSITION_TARGET_LOCAL_NED (as the simulated vehicle reads it),
COMMAND_LONG and its own HEARTBEAT.

Type masks are built from the named MAV_POSITION_TARGET_TYPEMASK bits (a set bit means
"ignore this field"). Both autopilots only honour whole groups, so position and velocity are
ignored or used on all three axes together.
"""
from __future__ import annotations

from collections.abc import Sequence

from pymavlink import mavutil

from uav_insar_planner.mavlink.guard import fits_float32
from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.plan import Vec3
from uav_insar_planner.track.frame import TrackFrame

_T = mavutil.mavlink
POSITION_BITS = (_T.POSITION_TARGET_TYPEMASK_X_IGNORE | _T.POSITION_TARGET_TYPEMASK_Y_IGNORE
                 | _T.POSITION_TARGET_TYPEMASK_Z_IGNORE)
VELOCITY_BITS = (_T.POSITION_TARGET_TYPEMASK_VX_IGNORE | _T.POSITION_TARGET_TYPEMASK_VY_IGNORE
                 | _T.POSITION_TARGET_TYPEMASK_VZ_IGNORE)
ACCELERATION_BITS = (_T.POSITION_TARGET_TYPEMASK_AX_IGNORE
                     | _T.POSITION_TARGET_TYPEMASK_AY_IGNORE
                     | _T.POSITION_TARGET_TYPEMASK_AZ_IGNORE)
YAW_BITS = _T.POSITION_TARGET_TYPEMASK_YAW_IGNORE | _T.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
#: Position + velocity feed-forward (3520): acceleration and yaw ignored.
MASK_POSITION_VELOCITY = ACCELERATION_BITS | YAW_BITS
#: Position only (3576): velocity, acceleration and yaw ignored.
MASK_POSITION = MASK_POSITION_VELOCITY | VELOCITY_BITS


def setpoint_message(mav: MAV.MAVLink, frame: TrackFrame, target: tuple[Vec3, Vec3],
                     boot_ms: int, sysid: int, compid: int,
                     feedforward: bool) -> MAV.MAVLink_message | None:
    """The setpoint for a track-frame (position, velocity) target, in MAV_FRAME_LOCAL_NED,
    or None when a value does not fit the float32 fields (guard.fits_float32: NaN, Inf or
    |v| > 3.4e38, before or after the rotation): nothing is sent then.

    With `feedforward` the velocity is sent too (MASK_POSITION_VELOCITY); otherwise the
    velocity fields are zero and ignored (MASK_POSITION).
    """
    n, e, d = frame.to_ned(*target[0])
    vn, ve, vd = frame.vector_to_ned(*target[1]) if feedforward else (0.0, 0.0, 0.0)
    if not fits_float32((n, e, d, vn, ve, vd)):
        return None
    mask = MASK_POSITION_VELOCITY if feedforward else MASK_POSITION
    return mav.set_position_target_local_ned_encode(
        boot_ms, sysid, compid, MAV.MAV_FRAME_LOCAL_NED, mask,
        n, e, d, vn, ve, vd, 0.0, 0.0, 0.0, 0.0, 0.0)


_FIELD_BITS = ((_T.POSITION_TARGET_TYPEMASK_X_IGNORE, _T.POSITION_TARGET_TYPEMASK_Y_IGNORE,
                _T.POSITION_TARGET_TYPEMASK_Z_IGNORE),
               (_T.POSITION_TARGET_TYPEMASK_VX_IGNORE, _T.POSITION_TARGET_TYPEMASK_VY_IGNORE,
                _T.POSITION_TARGET_TYPEMASK_VZ_IGNORE))


def used_values(type_mask: int, position: Vec3, velocity: Vec3) -> tuple[float, ...]:
    """The position and velocity fields a setpoint with `type_mask` uses (its ignore bit
    clear). An ignored field may hold anything, NaN included, as PX4 and ArduPilot allow."""
    return tuple(v for bits, values in zip(_FIELD_BITS, (position, velocity), strict=True)
                 for bit, v in zip(bits, values, strict=True) if not type_mask & bit)


def boot_ms(elapsed_s: float) -> int:
    """time_boot_ms of a message `elapsed_s` after the bridge started (wraps as uint32)."""
    return int(elapsed_s * 1000.0) & 0xFFFFFFFF


def command_message(mav: MAV.MAVLink, sysid: int, compid: int, command: int,
                    params: Sequence[float], confirmation: int = 0
                    ) -> MAV.MAVLink_message | None:
    """COMMAND_LONG with `params` padded to seven, or None when one does not fit float32."""
    p = [float(x) for x in params] + [0.0] * (7 - len(params))
    if not fits_float32(p):
        return None
    return mav.command_long_encode(sysid, compid, command, confirmation, *p)


def companion_heartbeat(mav: MAV.MAVLink) -> MAV.MAVLink_message:
    """The bridge's HEARTBEAT: an onboard controller, not an autopilot."""
    return mav.heartbeat_encode(MAV.MAV_TYPE_ONBOARD_CONTROLLER, MAV.MAV_AUTOPILOT_INVALID,
                                0, 0, MAV.MAV_STATE_ACTIVE)
