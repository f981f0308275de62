"""The MAVLink bridge node (`ros2 run uav_insar_planner mavlink_bridge`): a thin ROS adapter
over `uav_insar_planner.mavlink.bridge.Bridge`, which does all MAVLink work in its own thread.

Parameters (docs/mavlink.md has the full table):
  connections (string[]), target_sysids (int[]), source_sysid, track_bearing_deg,
  origin_ned_m (double[3], N E D), setpoint_rate_hz, velocity_feedforward, arm_and_takeoff,
  autopilot (ardupilot|px4), speed_mps, track_duration_s, capture_radius_m,
  heartbeat_timeout_s.
A bad value logs one line and exits with code 2 before anything is published or opened.

Subscribes  formation (geometry_msgs/PoseArray, reliable + transient_local, depth 1):
            poses[k] = (x_k, y_start, z_k) in the track frame; NaN for a UAV not flown.
Publishes   uav{K}/mavlink/pose (geometry_msgs/PoseStamped, frame insar_track), the
            vehicle's LOCAL_POSITION_NED in the track frame, each time a new one arrives;
            /diagnostics (diagnostic_msgs/DiagnosticArray) once a second, one status per UAV:
            link state, mode, arming sequence, position error, link counters.
"""
from __future__ import annotations

import math
import sys
from typing import Any

from uav_insar_planner.mavlink.bridge import Bridge, BridgeConfig, VehicleStatus
from uav_insar_planner.nodes.common import LATCHED, run_node
from uav_insar_planner.seam import (
    Node,
    ParameterDescriptor,
    msg_type,
)

PoseArray = msg_type("geometry_msgs/msg/PoseArray")
PoseStamped = msg_type("geometry_msgs/msg/PoseStamped")
DiagnosticArray = msg_type("diagnostic_msgs/msg/DiagnosticArray")
DiagnosticStatus = msg_type("diagnostic_msgs/msg/DiagnosticStatus")
KeyValue = msg_type("diagnostic_msgs/msg/KeyValue")

FRAME_ID = "insar_track"
POSE_PERIOD_S = 0.05  # poll the bridge at 20 Hz: vehicles report at ~10 Hz
DIAGNOSTICS_PERIOD_S = 1.0

#: (name, default, description); defaults pair with `uav-insar vehicle --sysid 2..4
#: --listen udpin:127.0.0.1:14552/14562/14572`.
PARAMETERS: tuple[tuple[str, Any, str], ...] = (
    ("connections", ["udpout:127.0.0.1:14552", "udpout:127.0.0.1:14562",
                     "udpout:127.0.0.1:14572"],
     "pymavlink connection string per UAV (or one shared): udpout:HOST:PORT, "
     "udpin:HOST:PORT, tcp:HOST:PORT, /dev/ttyUSB0,57600"),
    ("target_sysids", [2, 3, 4], "MAVLink system id of UAV 0, 1, 2 (1..255, distinct)"),
    ("source_sysid", 255, "our own system id (ArduPilot: match SYSID_MYGCS)"),
    ("track_bearing_deg", 0.0, "bearing of the along-track axis y from north [deg]"),
    ("origin_ned_m", [0.0, 0.0, 0.0], "track origin in local NED (N, E, D) [m]"),
    ("setpoint_rate_hz", 10.0, "SET_POSITION_TARGET_LOCAL_NED rate per UAV, 2..50 [Hz]"),
    ("velocity_feedforward", False, "send the along-track velocity too (type_mask 3520)"),
    ("arm_and_takeoff", False, "set GUIDED/OFFBOARD, arm and take off (default: you do)"),
    ("autopilot", "ardupilot", "ardupilot | px4: mode numbers and arming sequence"),
    ("speed_mps", 4.3, "along-track speed v_y [m/s]"),
    ("track_duration_s", 0.0, "length of the pass in time, then hold at its end; 0: no end"),
    ("capture_radius_m", 1.0, "start the pass when every UAV is this close to its start "
                              "point; 0: start at once [m]"),
    ("heartbeat_timeout_s", 5.0, "report a UAV lost after this long without heartbeat [s]"),
)


class MavlinkBridgeNode(Node):
    """See the module docstring. `problems` is non-empty (and nothing was created) when the
    parameters are invalid."""

    def __init__(self, node_name: str = "mavlink_bridge", **kwargs: Any):
        super().__init__(node_name, **kwargs)
        self.problems: list[str] = []
        self.bridge: Bridge | None = None
        values = self._declare()
        if self.problems:
            return
        try:
            config = BridgeConfig(
                connections=tuple(values["connections"]),
                target_sysids=tuple(values["target_sysids"]),
                source_sysid=values["source_sysid"],
                track_bearing_deg=values["track_bearing_deg"],
                origin_ned_m=tuple(values["origin_ned_m"]),
                setpoint_rate_hz=values["setpoint_rate_hz"],
                velocity_feedforward=values["velocity_feedforward"],
                arm_and_takeoff=values["arm_and_takeoff"],
                autopilot=values["autopilot"],
                speed_mps=values["speed_mps"],
                track_duration_s=values["track_duration_s"],
                capture_radius_m=values["capture_radius_m"],
                heartbeat_timeout_s=values["heartbeat_timeout_s"])
            self.bridge = Bridge(config)
        except ValueError as exc:
            self.problems.append(str(exc))
            return
        n = len(config.target_sysids)
        self._pose_pubs = [self.create_publisher(PoseStamped, f"uav{k}/mavlink/pose", 10)
                           for k in range(n)]
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._last_pose_age: list[float | None] = [None] * n
        self.create_subscription(PoseArray, "formation", self._on_formation, LATCHED)
        self.create_timer(POSE_PERIOD_S, self._publish_poses)
        self.create_timer(DIAGNOSTICS_PERIOD_S, self._publish_diagnostics)
        self.bridge.start()

    def _declare(self) -> dict[str, Any]:
        values: dict[str, Any] = {}
        for name, default, description in PARAMETERS:
            descriptor = ParameterDescriptor(description=description)
            try:
                self.declare_parameter(name, default, descriptor)
            except Exception as exc:  # rclpy's InvalidParameter*Exception share no base
                self.problems.append(f"{name}: {' '.join(str(exc).split())}")
                continue
            values[name] = self.get_parameter(name).value
        return values

    def stop(self) -> None:
        if self.bridge is not None:
            self.bridge.stop()

    def _on_formation(self, msg: Any) -> None:
        poses = []
        for pose in msg.poses:
            p = pose.position
            point = (float(p.x), float(p.y), float(p.z))
            poses.append(point if all(math.isfinite(c) for c in point) else None)
        self.bridge.set_formation(poses)
        flown = sum(p is not None for p in poses)
        self.get_logger().info(f"formation received: {flown} UAV(s) with a target")

    def _publish_poses(self) -> None:
        for event in self.bridge.drain_events():
            log = getattr(self.get_logger(), "warning" if event.level == "warn" else event.level)
            log(("swarm" if event.uav < 0 else f"uav{event.uav}") + ": " + event.text)
        stamp = self.get_clock().now().to_msg()
        for s in self.bridge.status():
            age = s.position_age_s
            fresh = age is not None and (self._last_pose_age[s.uav] is None
                                         or age < self._last_pose_age[s.uav])
            self._last_pose_age[s.uav] = age
            if not fresh or s.position_track is None:
                continue
            msg = PoseStamped()
            msg.header.stamp = stamp
            msg.header.frame_id = FRAME_ID
            msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = s.position_track
            msg.pose.orientation.w = 1.0
            self._pose_pubs[s.uav].publish(msg)

    def _publish_diagnostics(self) -> None:
        stats = self.bridge.link_stats()
        msg = DiagnosticArray()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.status = [self._vehicle_status(s, stats[s.connection])
                      for s in self.bridge.status()]
        self._diag_pub.publish(msg)

    def _vehicle_status(self, s: VehicleStatus, link: Any) -> Any:
        if s.sequence.startswith("failed"):
            level, text = DiagnosticStatus.ERROR, f"arming sequence {s.sequence}"
        elif s.link != "linked":
            level = DiagnosticStatus.WARN
            text = ("no heartbeat yet" if s.link == "waiting"
                    else f"lost: no heartbeat for {s.heartbeat_age_s:.1f} s")
        else:
            level = DiagnosticStatus.OK
            text = f"linked, {s.mode}, {'armed' if s.armed else 'disarmed'}"
        error = (math.dist(s.position_track, s.target_track)
                 if s.position_track is not None and s.target_track is not None else None)

        def fmt(v: Any) -> str:
            if v is None:
                return ""
            if isinstance(v, tuple):
                return " ".join(f"{c:.3f}" for c in v)
            return f"{v:.3f}" if isinstance(v, float) else str(v)

        values = [("connection", s.connection), ("sysid", s.sysid), ("compid", s.compid),
                  ("link", s.link), ("heartbeat_age_s", s.heartbeat_age_s), ("mode", s.mode),
                  ("armed", s.armed), ("sequence", s.sequence), ("last_ack", s.last_ack),
                  ("setpoints_sent", s.setpoints_sent), ("target_track_m", s.target_track),
                  ("position_track_m", s.position_track), ("position_error_m", error),
                  ("rx_messages", link.rx_messages), ("bad_data", link.bad_data),
                  ("truncated", link.truncated), ("unknown_msgid", link.unknown_msgid),
                  ("foreign", link.foreign), ("io_errors", link.io_errors)]
        return DiagnosticStatus(level=level, name=f"mavlink_bridge: uav{s.uav}",
                                message=text, hardware_id=f"mavlink sysid {s.sysid}",
                                values=[KeyValue(key=k, value=fmt(v)) for k, v in values])


def main(args: list[str] | None = None) -> int:
    """Run the bridge until Ctrl-C / SIGTERM; exit code 2 when the parameters are invalid."""
    return run_node(MavlinkBridgeNode, args)


if __name__ == "__main__":
    sys.exit(main())
