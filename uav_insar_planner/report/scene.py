"""The mission as geometry to draw (no ROS import): where each planned UAV is, its beam and
ground swath, the target line, the track, the ground station and each UAV's C9-C11 disk.

Track frame (topics.FRAME_ID): x across-track, y along-track, z up, metres. The formation
holds along the track, so a planned UAV k sits at (x_k, y, z_k) for y on the track
[0, N v_y delta_t] (slot n starts at y[n] = n v_y delta_t, equation (1), and lasts delta_t).
Its beam, centred on the target line at look angle theta_k (theta_0 for the master), lights
the ground from x_k + z_k tan(theta_k - Theta_3dB/2) to x_k + z_k tan(theta_k + Theta_3dB/2),
the swath of eq. 5 on flat ground. The C9-C11 disk of UAV k is the set of x-z positions
within rho_k of the station where its power and energy can meet R_min,k over the whole track
(solver.power.station_radius_sq); NaN when nothing limits it or no position can.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from uav_insar_planner import model
from uav_insar_planner.params import Params
from uav_insar_planner.plan import Plan, Vec3
from uav_insar_planner.solver.power import station_radius_sq


@dataclass(frozen=True)
class UavGeometry:
    """One flown UAV of a plan."""

    k: int
    position: Vec3  # (x_k, 0, z_k): the planned position at the track's start
    look_angle: float  # radians
    swath_x: tuple[float, float]  # ground x of the beam's near and far edge
    disk_radius: float  # rho_k [m], NaN when not finite / empty


@dataclass(frozen=True)
class Scene:
    uavs: list[UavGeometry]
    x_t: float
    track_y: tuple[float, float]  # along-track start and end of the slots
    station: Vec3


def swath_edges(x: float, z: float, look_angle: float, beamwidth: float) -> tuple[float, float]:
    """Ground x of the beam's two -3 dB edges seen from (x, z) at `look_angle` (flat ground)."""
    return (x + z * math.tan(look_angle - beamwidth / 2),
            x + z * math.tan(look_angle + beamwidth / 2))


def scene(p: Params, plan: Plan) -> Scene:
    """The drawable geometry of `plan` under scenario `p` (see the module docstring)."""
    uavs = []
    for k in plan.active_uavs:
        x, z = (float(v) for v in plan.formation[k])
        theta = p.theta0 if k == 0 else float(model.look_angle(x, z, p.x_t))
        rho2 = station_radius_sq(p, k, plan.scheme)
        radius = math.sqrt(rho2) if math.isfinite(rho2) and rho2 > 0 else math.nan
        uavs.append(UavGeometry(k, (x, 0.0, z), theta, swath_edges(x, z, theta, p.beamwidth),
                                radius))
    end = p.num_slots * p.speed * p.slot_duration_s
    station = tuple(float(v) for v in p.ground_station)
    return Scene(uavs, float(p.x_t), (0.0, float(end)), station)
