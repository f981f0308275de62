"""What the leaving-control tests hear (test_leaving_control.py on SITL-style vehicles,
test_sitl_px4.py on the real PX4): each bridge's /diagnostics status and every /formation with
its arrival time, a pilot's ground station, and the wall time of a log line."""
from __future__ import annotations

import math
import re
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray
from pymavlink import mavutil
from std_msgs.msg import Header

from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.published import bridge_status_name
from uav_insar_planner.ros import topics
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, uavs

UAVS = uavs(DEFAULT_NUM_UAVS)


class Heard:
    """What the test keeps with its arrival time (monotonic): each bridge's status and every
    /formation."""

    def __init__(self, watcher) -> None:
        self.status: dict[int, list[tuple[float, dict[str, str], str]]] = {k: [] for k in UAVS}
        self.formations: list[tuple[float, PoseArray]] = []
        self.starts: list[Header] = []
        node = watcher.node
        node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, self._diag,
                                 topics.RATE_DEPTH)
        node.create_subscription(PoseArray, "/" + topics.FORMATION,
                                 lambda m: self.formations.append((time.monotonic(), m)),
                                 topics.LATCHED)
        node.create_subscription(Header, "/" + topics.FORMATION_START, self.starts.append,
                                 topics.LATCHED)

    def _diag(self, msg: DiagnosticArray) -> None:
        for s in msg.status:
            for k in UAVS:
                if s.name == bridge_status_name(k):
                    self.status[k].append((time.monotonic(), {v.key: v.value for v in s.values},
                                           s.message))

    def without(self, k: int) -> float | None:
        """When the first /formation leaving UAV k out (NaN) arrived, None before."""
        for t, m in self.formations:
            if math.isnan(m.poses[k].position.x) and not math.isnan(m.poses[0].position.x):
                return t
        return None


def pilot(port: int) -> mavutil.mavfile:
    """A pilot's ground station (sysid 255, as every vehicle obeys) on the vehicle's port."""
    return mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255,
                                      source_component=MAV.MAV_COMP_ID_MISSIONPLANNER,
                                      dialect="ardupilotmega")


def log_wall_time(out: str, needle: str) -> float | None:
    """The wall-clock stamp of the first rclpy log line of `out` that contains `needle`."""
    for line in out.splitlines():
        if needle in line and (m := re.search(r"\[(\d+\.\d+)\]", line)):
            return float(m.group(1))
    return None
