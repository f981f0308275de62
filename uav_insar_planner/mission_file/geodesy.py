"""Local NED offsets about a home <-> WGS-84 latitude and longitude, on the tangent plane.

The offsets are scaled by the ellipsoid's radii of curvature at the home latitude phi0
(meridian M, prime vertical N):

    lat = lat0 + n / M(phi0),   lon = lon0 + e / (N(phi0) cos phi0)     (radians)

and back by the same two factors, so a round trip is exact to floating point. Against the
exact tangent-plane (ENU -> ECEF -> geodetic) conversion the horizontal error is second order
in the distance d from the home: below d^2 (1 + |tan phi0|) / a with a = 6378137 m (measured
against the exact conversion in test_export_mission.py, which finds at most 0.56 of it):
1.3 cm for d <= 200 m and 7.8 cm for d <= 500 m at |phi0| <= 45 deg. Heights are above the home
(MAV_FRAME_GLOBAL_RELATIVE_ALT), so they follow the ellipsoid, which falls d^2 / (2a) below
the tangent plane (2 cm at 500 m). Not for |phi0| near 90 deg: homes within
POLE_MARGIN_DEG of a pole are refused by the callers.
"""
from __future__ import annotations

import math

WGS84_A = 6378137.0  # semi-major axis [m]
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
POLE_MARGIN_DEG = 1.0  # cos(phi0) -> 0 at the poles: east offsets lose all meaning there


def radii_m(lat_deg: float) -> tuple[float, float]:
    """(M, N): the meridian and prime-vertical radii of curvature at latitude `lat_deg`."""
    s = math.sin(math.radians(lat_deg))
    w = 1.0 - WGS84_E2 * s * s
    return WGS84_A * (1.0 - WGS84_E2) / w**1.5, WGS84_A / math.sqrt(w)


def ned_to_latlon(home_lat_deg: float, home_lon_deg: float, north_m: float, east_m: float
                  ) -> tuple[float, float]:
    """(lat, lon) in degrees of the point `north_m`, `east_m` from the home; longitude wrapped
    into [-180, 180)."""
    m, n = radii_m(home_lat_deg)
    lat = home_lat_deg + math.degrees(north_m / m)
    lon = home_lon_deg + math.degrees(east_m / (n * math.cos(math.radians(home_lat_deg))))
    return lat, (lon + 180.0) % 360.0 - 180.0


def latlon_to_ned(home_lat_deg: float, home_lon_deg: float, lat_deg: float, lon_deg: float
                  ) -> tuple[float, float]:
    """(north, east) in metres of (lat, lon) from the home: the inverse of ned_to_latlon."""
    m, n = radii_m(home_lat_deg)
    dlon = (lon_deg - home_lon_deg + 180.0) % 360.0 - 180.0
    return (math.radians(lat_deg - home_lat_deg) * m,
            math.radians(dlon) * n * math.cos(math.radians(home_lat_deg)))
