"""The MAVLink bridge node (`ros2 run uav_insar_planner mavlink_bridge`): a thin ROS adapter
over `uav_insar_planner.mavlink.bridge.Bridge`, which does all MAVLink work in its own thread.

Parameters (param_specs/nodes.py BRIDGE_SPECS, all read-only: the links are opened once):
  uav_id (-1: every UAV of target_sysids, N entries for N UAVs; 0..num_uavs - 1: this UAV only, a
  stack per UAV, in namespace /uavK or the swarm's; another UAV's namespace is refused; a plan
  with fewer UAVs holds it, one line), pass_start (auto|capture|planner),
  connections (string[]), target_sysids (int[]), source_sysid, track_bearing_deg,
  origin_ned_m (double[3], N E D), setpoint_rate_hz, velocity_feedforward, arm_and_takeoff,
  autopilot (ardupilot|px4), speed_mps, track_duration_s, capture_radius_m,
  heartbeat_timeout_s, readiness_timeout_s, min_separation_m, signing_key_file,
  gcs_timeout_s (hold when the ground station is silent, mavlink/holds.py; auto: 5 s
  with uav_id, else off).
A bad value or unknown name logs one line and exits with code 2 before anything is published
or opened. Claims (ros/claims.py): no MAVLink byte for DISCOVERY_WINDOW_S; a UAV another bridge
on the graph claimed first is refused with one line, exit 2.

Subscribes  formation (geometry_msgs/PoseArray, reliable + transient_local, depth 1):
            poses[k] = (x_k, y_start, z_k) in the track frame; NaN for a UAV not flown;
            its frame_id may name a survey strip (plan_msgs.decode_leg): then the track frame
            is the strip's, placed on origin_ned_m (the survey's home in the vehicle's local
            NED), the pass is the strip's length, and after the sortie's last strip every
            vehicle returns to launch and lands (phase `returning`);
            and formation/power, only to know each formation's plan: like the agents, the
            bridge flies a formation only with the power message of the same plan identity
            and only while its planner is the sole publisher (ros/plan_gate.py), so with two
            planners on the domain it keeps the formation it flies. Both are validated at
            entry (ros/plan_msgs.py): a bad one is dropped with one rate-limited log line,
            counted (`bad_plan_messages` on /diagnostics), and the formation flown stays;
            gcs/heartbeat (std_msgs/Header, best effort, ros/gcs_link.py): with the plan
            and start messages, what tells the bridge the ground station is there
            (`gcs_timeout_s`); heard again after a hold through a plan other than the one
            flown (or a heartbeat naming one), the held vehicles wait for that plan;
            formation/start (std_msgs/Header, latched) with pass_start planner: the wall-clock
            start of the flown plan's pass (ros/start_msgs.py, validated, `bad_start_messages`).
Publishes   uav{K}/mavlink/claim (std_msgs/String, latched) per UAV flown (ros/claims.py);
            uav{K}/mavlink/pose (geometry_msgs/PoseStamped, frame insar_track), the
            vehicle's LOCAL_POSITION_NED in the track frame (the strip's during a survey),
            each time a new one arrives;
            /diagnostics (diagnostic_msgs/DiagnosticArray) once a second, one status per UAV:
            its `phase` (waiting for heartbeat / waiting for position / prearm: <reason> /
            armed / airborne / in formation / lost ...), link state, mode, arming sequence,
            PreArm reason, position error, separation warning, link counters, and the
            planner's start it flies (`pass_plan`, `pass_start`: its wall-clock instant; a
            resumed pass waits for them, ros/start_confirmations.py) and the v_y it flies
            (`speed_mps`: the planner names a bridge whose speed, and so whose entry, is not
            the plan's). Level ERROR:
            I/O thread dead or sequence failed; WARN: not linked, or planned closer than
            min_separation_m to another UAV, or holding because the ground station fell
            silent (phase `holding (LOITER): ...`; value `gcs`: the ground link); else
            OK. A vehicle that left our control (a failsafe, a pilot's mode change, a disarm,
            mavlink/control_states.py): WARN, phase and value `out_of_control` `out of our
            control: <mode>` (the planner's swarm watch re-plans without it), published at
            once, not at the next second. When the I/O thread dies the node publishes that
            ERROR once, logs why and exits with code 1 (exit_codes.EXIT_CRASH).
"""
from __future__ import annotations

import math
import sys
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node

from uav_insar_planner import published
from uav_insar_planner.exit_codes import EXIT_BAD_INPUT, EXIT_CRASH
from uav_insar_planner.mavlink.bridge import Bridge, VehicleStatus
from uav_insar_planner.mavlink.config import from_parameters
from uav_insar_planner.param_specs.nodes import BRIDGE_SPECS
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.claims import DISCOVERY_WINDOW_S, UavClaims
from uav_insar_planner.ros.gcs_link import GcsLink
from uav_insar_planner.ros.parameters import (
    declare_specs,
    guard_sets,
    spec_values,
    unknown_overrides,
)
from uav_insar_planner.ros.plan_gate import PlanGate
from uav_insar_planner.ros.plan_msgs import Formation, PowerSchedule
from uav_insar_planner.ros.run import run_node
from uav_insar_planner.ros.start_msgs import StartFollower
from uav_insar_planner.swarm import uav_name

POSE_PERIOD_S = 0.05  # poll the bridge at 20 Hz: vehicles report at ~10 Hz
DIAGNOSTICS_PERIOD_S = 1.0


class MavlinkBridgeNode(Node):
    """See the module docstring. `problems` is non-empty (and nothing was created) when the
    parameters are invalid."""

    def __init__(self, node_name: str = "mavlink_bridge", **kwargs: Any):
        super().__init__(node_name, **kwargs)
        self.bridge: Bridge | None = None
        self.problems = declare_specs(self, BRIDGE_SPECS, read_only=True)
        self.problems += unknown_overrides(self)
        if self.problems:
            return
        values = spec_values(self, BRIDGE_SPECS)
        try:
            config = from_parameters(values)
            config.validate()
            k = config.uav_id
            ns = topics.swarm_namespace(self.get_namespace(), k if k >= 0 else None)
            self.bridge = Bridge(config)
        except (TypeError, ValueError) as exc:
            self.problems.append(str(exc))
            return
        uavs = self.bridge.uavs
        self._pose_pubs = {k: self.create_publisher(PoseStamped, topics.resolve(
            ns, topics.mavlink_pose(k)), topics.DEPTH) for k in uavs}
        self._diag_pub = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, topics.DEPTH)
        self._last_pose_age: dict[int, float | None] = dict.fromkeys(uavs)
        self._out_of_control: dict[int, str] = {}  # as last published
        self.gcs = GcsLink(self, self.bridge.gcs_heard, ns, lambda: self._gate.current)
        self._gate = PlanGate(self, self._on_plan, swarm_ns=ns,  # validated, one at a time
                              on_message=self.gcs.heard)
        self._starts = (StartFollower(self, ns, lambda: self._gate.current,
                                      self.bridge.set_start, on_message=self.gcs.heard)
                        if config.pass_start == "planner" else None)
        self.create_timer(POSE_PERIOD_S, self._publish_poses)
        self.create_timer(DIAGNOSTICS_PERIOD_S, self._publish_diagnostics)
        guard_sets(self)
        # No MAVLink byte before no other bridge on the graph flies these UAVs (claims.py).
        self._claims = UavClaims(self, ns, uavs, on_granted=self._granted,
                                 on_refused=self._refused)

    def _granted(self) -> None:
        self.get_logger().info(f"{', '.join(uav_name(k) for k in self.bridge.uavs)}: no other "
                               f"bridge claims it ({DISCOVERY_WINDOW_S:g} s discovery window); "
                               "flying")
        self.bridge.start()

    def _refused(self, line: str) -> None:
        self.get_logger().error(line)
        raise SystemExit(EXIT_BAD_INPUT)

    def stop(self) -> None:
        if self.bridge is not None:
            self.bridge.stop()
            self._log_events()  # what the I/O thread did since the last tick is still said

    def _on_plan(self, formation: Formation, power: PowerSchedule) -> None:
        poses = list(formation.points)
        self.bridge.set_formation(poses, formation.leg)
        if self._starts is not None:
            self._starts.plan_adopted()
        flown = sum(p is not None for p in poses)
        self.get_logger().info(f"formation received: {flown} UAV(s) with a target "
                               f"({power.plan_id}" + (f", {formation.leg.describe()}"
                                                      if formation.leg else "") + ")")
        beyond = [k for k in self.bridge.uavs if k >= len(poses)]
        if beyond:  # (clean_formation gives them no target: they hold)
            self.get_logger().warning(
                f"{power.plan_id} flies {len(poses)} UAVs (uav0..uav{len(poses) - 1}); "
                f"{', '.join(uav_name(k) for k in beyond)} not in it: holding")
        elif self.bridge.config.uav_id < 0 and len(self.bridge.uavs) < len(poses):
            self.get_logger().warning(
                f"{power.plan_id} flies {len(poses)} UAVs; this bridge has target_sysids for "
                f"{len(self.bridge.uavs)} and flies only those")

    def _log_events(self) -> None:
        """Logs the bridge's events since the last call (its I/O thread cannot log)."""
        logger = self.get_logger()
        for event in self.bridge.drain_events():
            text = ("swarm" if event.uav < 0 else uav_name(event.uav)) + ": " + event.text
            # rclpy ties a severity to each call site: one call per severity.
            if event.level == "error":
                logger.error(text)
            elif event.level == "warn":
                logger.warning(text)
            else:
                logger.info(text)

    def _publish_poses(self) -> None:
        self._log_events()
        stamp = self.get_clock().now().to_msg()
        statuses = self.bridge.status()
        if {s.uav: s.out_of_control for s in statuses if s.out_of_control} != \
                self._out_of_control:  # a vehicle taken from us is said at once
            self._publish_diagnostics()
        for s in statuses:
            age = s.position_age_s
            fresh = age is not None and (self._last_pose_age[s.uav] is None
                                         or age < self._last_pose_age[s.uav])
            self._last_pose_age[s.uav] = age
            if not fresh or s.position_track is None:
                continue
            msg = PoseStamped()
            msg.header.stamp = stamp
            msg.header.frame_id = topics.FRAME_ID
            msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = s.position_track
            msg.pose.orientation.w = 1.0
            self._pose_pubs[s.uav].publish(msg)

    def _publish_diagnostics(self) -> None:
        if not self._claims.granted:
            return  # not flying (yet): UAV K's status is the bridge's that flies it
        stats = self.bridge.link_stats()
        self._gcs_state = self.bridge.gcs_state()
        msg = DiagnosticArray()
        msg.header.stamp = self.get_clock().now().to_msg()
        statuses = self.bridge.status()
        msg.status = [self._vehicle_status(s, stats[s.connection]) for s in statuses]
        self._out_of_control = {s.uav: s.out_of_control for s in statuses if s.out_of_control}
        self._diag_pub.publish(msg)
        if self.bridge.failure is not None:  # said ERROR once: now leave, never a zombie
            self._publish_poses()  # (drains the event that says why)
            raise SystemExit(EXIT_CRASH)

    def _vehicle_status(self, s: VehicleStatus, link: Any) -> Any:
        if self.bridge.failure is not None:
            level, text = DiagnosticStatus.ERROR, ("MAVLink I/O thread died, nothing is sent: "
                                                   + self.bridge.failure)
        elif s.sequence.startswith("failed"):
            level, text = DiagnosticStatus.ERROR, f"arming sequence {s.sequence}"
        elif s.link != "linked":
            level = DiagnosticStatus.WARN
            text = ("waiting for heartbeat" if s.link == "waiting"
                    else f"lost: no heartbeat for {s.heartbeat_age_s:.1f} s")
        else:
            level = DiagnosticStatus.OK
            text = f"linked, {s.mode}, {'armed' if s.armed else 'disarmed'}: {s.phase}"
        if s.separation:
            level = max(level, DiagnosticStatus.WARN)
            text += f"; planned too close: {s.separation}"
        if s.behind:
            text += f"; cannot keep the pass of {s.pass_plan or 'its plan'}"
        if (s.phase.startswith("holding") or s.out_of_control) and level == DiagnosticStatus.OK:
            level = DiagnosticStatus.WARN
        error = (math.dist(s.position_track, s.target_track)
                 if s.position_track is not None and s.target_track is not None else None)

        def fmt(v: Any) -> str:
            if v is None:
                return ""
            if isinstance(v, tuple):
                return " ".join(f"{c:.3f}" for c in v)
            return f"{v:.3f}" if isinstance(v, float) else str(v)

        values = [("phase", s.phase), ("connection", s.connection), ("sysid", s.sysid),
                  ("compid", s.compid), ("link", s.link), ("link_up", s.link_up),
                  ("heartbeat_age_s", s.heartbeat_age_s), ("mode", s.mode),
                  ("armed", s.armed), ("sequence", s.sequence), ("prearm", s.prearm),
                  ("last_ack", s.last_ack), ("separation", s.separation),
                  ("setpoints_sent", s.setpoints_sent), ("target_track_m", s.target_track),
                  ("position_track_m", s.position_track), ("position_error_m", error),
                  ("rx_messages", link.rx_messages), ("bad_data", link.bad_data),
                  ("truncated", link.truncated), ("unknown_msgid", link.unknown_msgid),
                  ("foreign", link.foreign), ("io_errors", link.io_errors),
                  ("bad_plan_messages", self._gate.dropped), ("gcs", self._gcs_state),
                  ("bad_start_messages", self._starts.dropped if self._starts else 0),
                  ("bad_claim_messages", self._claims.dropped),
                  ("bad_signature", link.bad_signature), ("spoofed", link.spoofed),
                  ("bad_value", link.bad_value), ("unsendable", link.unsendable),
                  ("pass_plan", s.pass_plan), ("pass_start", s.pass_start_s),
                  ("behind", s.behind), ("out_of_control", s.out_of_control),
                  ("speed_mps", self.bridge.config.speed_mps)]
        return DiagnosticStatus(level=level, name=published.bridge_status_name(s.uav),
                                message=text, hardware_id=f"mavlink sysid {s.sysid}",
                                values=[KeyValue(key=k, value=fmt(v)) for k, v in values])


def main(args: list[str] | None = None) -> int:
    """Run the bridge until Ctrl-C / SIGTERM; exit code 2 when the parameters are invalid."""
    return run_node(MavlinkBridgeNode, "mavlink_bridge", args)


if __name__ == "__main__":
    sys.exit(main())
