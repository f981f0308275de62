"""The parameters of the simulated vehicle and their MAVLink encoding.

A handful per autopilot, under the names the real one uses (SIM_* ones are the simulator's
own). Integers are MAV_PARAM_TYPE_INT32, the rest REAL32. On the wire ArduPilot sends every
value cast to float (MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST), PX4 puts the int32 bytes
into the float field (PARAM_ENCODE_BYTEWISE), as MAVSDK and QGC expect of each.

`ParamTable.set(name, raw)` accepts only a finite value inside the parameter's range (else
the value stays); read-only parameters keep their value too. Either way the caller answers
with the PARAM_VALUE of the (possibly unchanged) value, as the autopilots do.
"""
from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import dataclass

from uav_insar_planner.mavlink.link import MAV

INT32, REAL32 = MAV.MAV_PARAM_TYPE_INT32, MAV.MAV_PARAM_TYPE_REAL32


@dataclass
class Param:
    """One parameter: `get` / `put` work in the parameter's own unit; `put` None = read-only."""
    name: str
    kind: int
    low: float
    high: float
    get: Callable[[], float]
    put: Callable[[float], None] | None = None


def _const(value: float) -> Callable[[], float]:
    return lambda: value


def _getter(obj: object, attr: str, scale: float = 1.0) -> Callable[[], float]:
    return lambda: getattr(obj, attr) * scale


def _setter(obj: object, attr: str, scale: float = 1.0) -> Callable[[float], None]:
    return lambda v: setattr(obj, attr, v / scale)


def _common(vehicle, gcs_name: str) -> tuple[Param, Param]:
    """The GCS sysid (under `gcs_name`) and the simulator's boot time, on every flavour."""
    return (Param(gcs_name, INT32, 0, 255, _getter(vehicle, "gcs_sysid"),
                  _setter(vehicle, "gcs_sysid")),
            Param("SIM_BOOT_TIME", REAL32, 0, 3600, _getter(vehicle._ap, "boot_s")))


def px4_params(vehicle) -> list[Param]:
    """The parameter list of a PX4-like `SimVehicle`."""
    ap = vehicle._ap
    gcs, boot = _common(vehicle, "SIM_GCS_SYSID")
    return [
        Param("MAV_SYS_ID", INT32, 1, 255, _const(vehicle.sysid)),
        gcs,
        Param("MPC_XY_VEL_MAX", REAL32, 0.1, 50, _getter(ap, "max_speed"),
              _setter(ap, "max_speed")),
        Param("MPC_ACC_HOR_MAX", REAL32, 0.1, 30, _getter(ap, "max_accel"),
              _setter(ap, "max_accel")),
        Param("MIS_TAKEOFF_ALT", REAL32, 0.5, 1000, _getter(ap, "takeoff_alt_m"),
              _setter(ap, "takeoff_alt_m")),
        Param("RTL_RETURN_ALT", REAL32, 0, 1000, _getter(ap, "rtl_alt_m"),
              _setter(ap, "rtl_alt_m")),
        Param("COM_OF_LOSS_T", REAL32, 0.1, 60, _getter(ap, "offboard_timeout_s"),
              _setter(ap, "offboard_timeout_s")),
        Param("CAL_GYRO0_ID", INT32, -2**31, 2**31 - 1, _const(1310988)),
        Param("CAL_ACC0_ID", INT32, -2**31, 2**31 - 1, _const(1310988)),
        Param("CAL_MAG0_ID", INT32, -2**31, 2**31 - 1, _const(197388)),
        Param("SYS_HITL", INT32, 0, 2, _const(0)),
        boot,
    ]


def copter_params(vehicle) -> list[Param]:
    """The parameter list of an ArduCopter-like `SimVehicle`."""
    ap = vehicle._ap
    gcs, boot = _common(vehicle, "MAV_GCS_SYSID")
    return [
        Param("SYSID_THISMAV", INT32, 1, 255, _const(vehicle.sysid)),
        gcs,
        Param("WPNAV_SPEED", REAL32, 10, 5000, _getter(ap, "max_speed", 100.0),
              _setter(ap, "max_speed", 100.0)),
        Param("WPNAV_ACCEL", REAL32, 10, 3000, _getter(ap, "max_accel", 100.0),
              _setter(ap, "max_accel", 100.0)),
        Param("RTL_ALT", REAL32, 0, 300000, _getter(ap, "rtl_alt_m", 100.0),
              _setter(ap, "rtl_alt_m", 100.0)),
        Param("PILOT_TKOFF_ALT", REAL32, 0, 100000, _getter(ap, "takeoff_alt_m", 100.0),
              _setter(ap, "takeoff_alt_m", 100.0)),
        *(Param(f"{group}_{axis}", REAL32, -10, 10, _const(value))
          for group, value in (("INS_GYROFFS", 0.001), ("INS_ACCOFFS", 0.01),
                               ("COMPASS_OFS", 5.0)) for axis in "XYZ"),
        boot,
    ]


class ParamTable:
    """Name / index lookup, range-checked set, and wire encoding (see the module doc)."""

    def __init__(self, params: list[Param], bytewise: bool):
        self.params = params
        self.bytewise = bytewise
        self._index = {p.name: i for i, p in enumerate(params)}

    def __len__(self) -> int:
        return len(self.params)

    def find(self, name: str, index: int) -> int | None:
        """Index of the parameter asked for by PARAM_REQUEST_READ (index -1: by name)."""
        if index >= 0:
            return index if index < len(self.params) else None
        return self._index.get(name)

    def set(self, name: str, raw: float, kind: int) -> int | None:
        """PARAM_SET: returns the index (None for an unknown name); the value may stay."""
        i = self._index.get(name)
        if i is None:
            return None
        p = self.params[i]
        value = self.decode(raw, kind)
        if p.put is not None and value is not None and p.low <= value <= p.high:
            p.put(float(round(value)) if p.kind == INT32 else float(value))
        return i

    def encode(self, i: int) -> float:
        """The PARAM_VALUE.param_value of parameter `i`."""
        p = self.params[i]
        value = p.get()
        if p.kind == INT32:
            value = int(round(value))
            if self.bytewise:
                return struct.unpack("<f", struct.pack("<i", value))[0]
        return float(value)

    def decode(self, raw: float, kind: int) -> float | None:
        """PARAM_SET.param_value -> a number (None: not a usable value)."""
        if self.bytewise and kind in (MAV.MAV_PARAM_TYPE_INT32, MAV.MAV_PARAM_TYPE_UINT32,
                                      MAV.MAV_PARAM_TYPE_INT16, MAV.MAV_PARAM_TYPE_UINT16,
                                      MAV.MAV_PARAM_TYPE_INT8, MAV.MAV_PARAM_TYPE_UINT8):
            try:
                return float(struct.unpack("<i", struct.pack("<f", raw))[0])
            except (OverflowError, struct.error):
                return None
        return raw if math.isfinite(raw) else None
