"""Track frame `insar_track` <-> local NED (MAVLink's LOCAL_POSITION_NED frame, mavros' too).

Track frame: x = range / across-track, y = azimuth / along-track, z = up (metres).
The along-track axis points at bearing psi from north (clockwise, radians inside), and the
track origin sits at `origin_ned` in the vehicle's local NED frame (the EKF origin frame):

    N = y cos psi - x sin psi + N0
    E = y sin psi + x cos psi + E0
    D = -z + D0

psi = 0 gives mavros' convention (N, E, D) = (y, x, -z). The map is a rotation about the
vertical plus a shift, so the inverse is exact.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from uav_insar_planner.plan import Vec3


@dataclass(frozen=True)
class TrackFrame:
    """The placement of the track frame in local NED: bearing (rad) and origin (m, NED)."""

    bearing_rad: float = 0.0
    origin_ned: Vec3 = (0.0, 0.0, 0.0)

    @classmethod
    def from_degrees(cls, bearing_deg: float, origin_ned: Vec3 = (0.0, 0.0, 0.0)) -> TrackFrame:
        """Build from a bearing in degrees (the parameter's unit at the edge)."""
        return cls(math.radians(bearing_deg), tuple(float(v) for v in origin_ned))

    def vector_to_ned(self, x: float, y: float, z: float) -> Vec3:
        """Rotate a free vector (velocity, offset) from track axes to NED axes."""
        c, s = math.cos(self.bearing_rad), math.sin(self.bearing_rad)
        return (y * c - x * s, y * s + x * c, -z)

    def vector_from_ned(self, n: float, e: float, d: float) -> Vec3:
        """Rotate a free vector from NED axes to track axes."""
        c, s = math.cos(self.bearing_rad), math.sin(self.bearing_rad)
        return (-n * s + e * c, n * c + e * s, -d)

    def to_ned(self, x: float, y: float, z: float) -> Vec3:
        """Point in the track frame -> point in local NED."""
        n, e, d = self.vector_to_ned(x, y, z)
        n0, e0, d0 = self.origin_ned
        return (n + n0, e + e0, d + d0)

    def from_ned(self, n: float, e: float, d: float) -> Vec3:
        """Point in local NED -> point in the track frame."""
        n0, e0, d0 = self.origin_ned
        return self.vector_from_ned(n - n0, e - e0, d - d0)
