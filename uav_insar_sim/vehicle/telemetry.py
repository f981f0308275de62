"""The telemetry of the simulated vehicle: what each message says and how often it is sent.

Every message is built from the simulated state (`Autopilot`), its position as the estimate
reports it (`EstimateError`: position messages only), and the geodetic position of
the local NED origin (`origin` = (lat deg, lon deg, alt m AMSL); flat earth around it). The
vehicle never yaws, so heading is 0 and roll / pitch follow the horizontal acceleration.

`Streams` holds one interval per streamed message (seconds; 0 = off) with the defaults below
and answers MAV_CMD_SET_MESSAGE_INTERVAL: -1 off, 0 default, > 0 microseconds (faster than
`MIN_INTERVAL_S` is clamped, as autopilots cap rates). `build(kind, ...)` returns the message
or None while it is not available yet (no position before the boot phase ends).
"""
from __future__ import annotations

import math
from collections.abc import Callable

from uav_insar_planner.mavlink.link import MAV
from uav_insar_sim.vehicle.estimate_error import EstimateError

EARTH_RADIUS_M = 6378137.0
SITL_HOME = (-35.363261, 149.165230, 584.0)  # ArduPilot SITL's default (CMAC)
MIN_INTERVAL_S = 0.02
MAX_INTERVAL_US = 100e6
G = 9.80665

M = MAV
#: message id -> default interval [s] (0: only on request).
DEFAULT_INTERVALS = {
    M.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    M.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    M.MAVLINK_MSG_ID_GPS_RAW_INT: 0.5,
    M.MAVLINK_MSG_ID_ATTITUDE: 0.1,
    M.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 0.1,
    M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 0.2,
    M.MAVLINK_MSG_ID_HOME_POSITION: 2.0,
    M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    M.MAVLINK_MSG_ID_BATTERY_STATUS: 2.0,
    M.MAVLINK_MSG_ID_AUTOPILOT_VERSION: 0.0,
    M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: 0.0,
}
#: Messages that exist only once the boot phase is over (position estimate and home).
NEEDS_POSITION = frozenset((M.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
                            M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
                            M.MAVLINK_MSG_ID_HOME_POSITION, M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN))
SENSORS = (M.MAV_SYS_STATUS_SENSOR_3D_GYRO | M.MAV_SYS_STATUS_SENSOR_3D_ACCEL
           | M.MAV_SYS_STATUS_SENSOR_3D_MAG | M.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
           | M.MAV_SYS_STATUS_SENSOR_GPS | M.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
           | M.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION | M.MAV_SYS_STATUS_SENSOR_YAW_POSITION
           | M.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
           | M.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL | M.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
           | M.MAV_SYS_STATUS_AHRS | M.MAV_SYS_STATUS_SENSOR_BATTERY
           | M.MAV_SYS_STATUS_PREARM_CHECK)
NOT_HEALTHY_WHILE_BOOTING = (M.MAV_SYS_STATUS_SENSOR_GPS | M.MAV_SYS_STATUS_AHRS
                             | M.MAV_SYS_STATUS_PREARM_CHECK)
CAPABILITIES = (M.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | M.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
                | M.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | M.MAV_PROTOCOL_CAPABILITY_MISSION_INT)  # uploads: vehicle/mission_upload
CELLS, CELL_FULL_MV, CELL_EMPTY_MV = 4, 4200, 3500
BATTERY_DRAIN_PER_S = 0.05  # % per second while armed (~33 min from full)


def parse_home(text: str) -> tuple[float, float, float]:
    """'LAT,LON,ALT' -> (lat deg, lon deg, alt m AMSL); ValueError when it is not sensible."""
    try:
        lat, lon, alt = (float(p) for p in text.split(","))
    except ValueError:
        raise ValueError(f"home: {text!r} is not allowed; expected LAT,LON,ALT") from None
    check_home((lat, lon, alt))
    return lat, lon, alt


def check_home(home: tuple[float, float, float]) -> None:
    lat, lon, alt = home
    if not (abs(lat) < 89.0 and abs(lon) <= 180.0 and -500.0 < alt < 10000.0):
        raise ValueError(f"home: {home!r} is not allowed; expected |lat| < 89, |lon| <= 180, "
                         "-500 < alt < 10000 m")


class Streams:
    """Intervals and due times of the streamed messages (see the module doc)."""

    def __init__(self) -> None:
        self.interval = dict(DEFAULT_INTERVALS)
        self._due = dict.fromkeys(self.interval, 0.0)

    def set_interval(self, msgid: int, us: float) -> bool:
        """SET_MESSAGE_INTERVAL semantics; False (nothing changed) for garbage."""
        if msgid not in self.interval or not math.isfinite(us):
            return False
        if us == -1:
            self.interval[msgid] = 0.0
        elif us == 0:
            self.interval[msgid] = DEFAULT_INTERVALS[msgid]
        elif 0 < us <= MAX_INTERVAL_US:
            self.interval[msgid] = max(us * 1e-6, MIN_INTERVAL_S)
        else:
            return False
        self._due[msgid] = 0.0
        return True

    def due(self, now: float) -> list[int]:
        """Message ids to send now (their next time is booked)."""
        out = []
        for msgid, interval in self.interval.items():
            if interval > 0 and now >= self._due[msgid]:
                out.append(msgid)
                self._due[msgid] = max(self._due[msgid] + interval, now)
        return out


class Telemetry:
    """Builds the messages of one vehicle (see the module doc); `mav` encodes them."""

    def __init__(self, mav: MAV.MAVLink, ap, origin: tuple[float, float, float],
                 boot_time: float, sysid: int, error: EstimateError | None = None):
        check_home(origin)
        self.mav, self.ap, self.origin, self.boot_time = mav, ap, origin, boot_time
        self.error = EstimateError() if error is None else error
        self.sysid = sysid
        self.battery = 100.0
        self._last_v, self._last_t = (0.0, 0.0, 0.0), boot_time
        self._tilt = (0.0, 0.0)
        self._builders: dict[int, Callable[[float], MAV.MAVLink_message]] = {
            M.MAVLINK_MSG_ID_SYS_STATUS: self.sys_status,
            M.MAVLINK_MSG_ID_GPS_RAW_INT: self.gps_raw_int,
            M.MAVLINK_MSG_ID_ATTITUDE: self.attitude,
            M.MAVLINK_MSG_ID_LOCAL_POSITION_NED: self.local_position_ned,
            M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: self.global_position_int,
            M.MAVLINK_MSG_ID_HOME_POSITION: self.home_position,
            M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: self.extended_sys_state,
            M.MAVLINK_MSG_ID_BATTERY_STATUS: self.battery_status,
            M.MAVLINK_MSG_ID_AUTOPILOT_VERSION: self.autopilot_version,
            M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: self.gps_global_origin,
        }

    def can_build(self, msgid: int) -> bool:
        return msgid in self._builders or msgid == M.MAVLINK_MSG_ID_HEARTBEAT

    def build(self, msgid: int, now: float, booted: bool) -> MAV.MAVLink_message | None:
        if msgid in NEEDS_POSITION and not booted:
            return None
        builder = self._builders.get(msgid)
        return None if builder is None else builder(now)

    def update(self, now: float) -> None:
        """Per physics tick: battery drain, tilt from the horizontal acceleration, the
        estimate's error."""
        dt = now - self._last_t
        if dt <= 0:
            return
        self.error.step(dt)
        v = self.ap.velocity
        an, ae = (v[0] - self._last_v[0]) / dt, (v[1] - self._last_v[1]) / dt
        self._tilt = (math.atan2(ae, G), -math.atan2(an, G))
        self._last_v, self._last_t = v, now
        if self.ap.armed:
            self.battery = max(0.0, self.battery - BATTERY_DRAIN_PER_S * dt)

    # ------------------------------------------------------------------------ geometry
    def position(self) -> tuple[float, float, float]:
        """The position estimate (NED, m): where the vehicle is, off by the error."""
        return self.error.reported(self.ap.position)

    def geodetic(self, n: float, e: float, d: float) -> tuple[int, int, int]:
        """NED [m] -> (lat degE7, lon degE7, alt mm AMSL)."""
        lat0, lon0, alt0 = self.origin
        lat = lat0 + math.degrees(n / EARTH_RADIUS_M)
        lon = lon0 + math.degrees(e / (EARTH_RADIUS_M * math.cos(math.radians(lat0))))
        return round(lat * 1e7), round(lon * 1e7), round((alt0 - d) * 1000.0)

    def _ms(self, now: float) -> int:
        return int((now - self.boot_time) * 1000.0) & 0xFFFFFFFF

    def _voltage_mv(self) -> int:
        return round(CELLS * (CELL_EMPTY_MV + (CELL_FULL_MV - CELL_EMPTY_MV)
                              * self.battery / 100.0))

    def _current_ca(self) -> int:
        return 1500 if self.ap.armed else 50  # 15 A hovering, 0.5 A idle

    # ------------------------------------------------------------------------ messages
    def heartbeat(self, now: float) -> MAV.MAVLink_message:
        """MAV_TYPE_QUADROTOR; ArduCopter mode numbers or PX4 main << 16 | sub << 24."""
        ap, p = self.ap, self.ap.profile
        flags = M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | p.heartbeat_flags
        if ap.armed:
            flags |= M.MAV_MODE_FLAG_SAFETY_ARMED
        if ap.mode == "GUIDED":
            flags |= M.MAV_MODE_FLAG_GUIDED_ENABLED
        if not ap.booted(now):
            state = p.boot_state
        elif ap.armed and not ap.on_ground():
            state = M.MAV_STATE_ACTIVE
        else:
            state = M.MAV_STATE_STANDBY
        return self.mav.heartbeat_encode(M.MAV_TYPE_QUADROTOR, p.autopilot.mav_autopilot, flags,
                                         p.custom_mode(ap.mode), state)

    def sys_status(self, now: float) -> MAV.MAVLink_message:
        health = SENSORS if self.ap.booted(now) else SENSORS & ~NOT_HEALTHY_WHILE_BOOTING
        return self.mav.sys_status_encode(SENSORS, SENSORS, health, 200, self._voltage_mv(),
                                          self._current_ca(), round(self.battery),
                                          0, 0, 0, 0, 0, 0)

    def gps_raw_int(self, now: float) -> MAV.MAVLink_message:
        booted = self.ap.booted(now)
        lat, lon, alt = self.geodetic(*self.position()) if booted else (0, 0, 0)
        vn, ve, _ = self.ap.velocity
        speed = math.hypot(vn, ve)
        cog = round(math.degrees(math.atan2(ve, vn)) % 360.0 * 100) % 36000 if speed > 0.2 \
            else 65535
        fix = M.GPS_FIX_TYPE_3D_FIX if booted else M.GPS_FIX_TYPE_NO_FIX
        return self.mav.gps_raw_int_encode(int((now - self.boot_time) * 1e6), fix, lat, lon,
                                           alt, 80 if booted else 9999, 120 if booted else 9999,
                                           round(speed * 100), cog, 10 if booted else 0,
                                           alt, 500, 800, 100, 0, 0)

    def attitude(self, now: float) -> MAV.MAVLink_message:
        roll, pitch = self._tilt
        return self.mav.attitude_encode(self._ms(now), roll, pitch, 0.0, 0.0, 0.0, 0.0)

    def local_position_ned(self, now: float) -> MAV.MAVLink_message:
        return self.mav.local_position_ned_encode(self._ms(now), *self.position(),
                                                  *self.ap.velocity)

    def global_position_int(self, now: float) -> MAV.MAVLink_message:
        n, e, d = self.position()
        lat, lon, alt = self.geodetic(n, e, d)
        vn, ve, vd = (round(v * 100) for v in self.ap.velocity)
        relative = round((float(self.ap.home[2]) - d) * 1000.0)
        return self.mav.global_position_int_encode(self._ms(now), lat, lon, alt, relative,
                                                   vn, ve, vd, 0)

    def home_position(self, now: float) -> MAV.MAVLink_message:
        hn, he, hd = (float(c) for c in self.ap.home)
        lat, lon, alt = self.geodetic(hn, he, hd)
        return self.mav.home_position_encode(lat, lon, alt, hn, he, hd, (1.0, 0.0, 0.0, 0.0),
                                             0.0, 0.0, 0.0, int((now - self.boot_time) * 1e6))

    def gps_global_origin(self, now: float) -> MAV.MAVLink_message:
        lat, lon, alt = self.geodetic(0.0, 0.0, 0.0)
        return self.mav.gps_global_origin_encode(lat, lon, alt,
                                                 int((now - self.boot_time) * 1e6))

    def extended_sys_state(self, now: float) -> MAV.MAVLink_message:
        return self.mav.extended_sys_state_encode(M.MAV_VTOL_STATE_UNDEFINED,
                                                  self.ap.landed_state())

    def battery_status(self, now: float) -> MAV.MAVLink_message:
        cell = self._voltage_mv() // CELLS
        voltages = [cell] * CELLS + [65535] * (10 - CELLS)
        return self.mav.battery_status_encode(0, M.MAV_BATTERY_FUNCTION_ALL,
                                              M.MAV_BATTERY_TYPE_LIPO, 32767, voltages,
                                              self._current_ca(), -1, -1, round(self.battery))

    def autopilot_version(self, now: float) -> MAV.MAVLink_message:
        major, minor, patch, kind = self.ap.profile.version
        encoding = (M.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
                    if self.ap.profile.bytewise_params
                    else M.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST)
        return self.mav.autopilot_version_encode(
            CAPABILITIES | encoding, major << 24 | minor << 16 | patch << 8 | kind, 0, 0, 0,
            [0] * 8, [0] * 8, [0] * 8, 0, 0, 0x5349_4D00_0000_0000 | self.sysid)
