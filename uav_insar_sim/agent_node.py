"""The simulated UAV agent (`ros2 run uav_insar_planner agent --ros-args -p uav_id:=1`).

Runs beside the planner or, as a stack on the UAV's computer, in the UAV's own namespace
(`-r __ns:=/uav1 -p uav_id:=1`, node /uav1/agent); its topics are the swarm's either way
(topics.swarm_namespace: /uav1/pose, /formation).

Waits for the latched `formation` and `formation/power` of one plan (ros/plan_gate.py: both
validated, of the same plan identity, from the sole planner on the domain; the plan flown is
logged and published on `uav{K}/plan`), flies to its across-track target
(x_k, z_k), then runs the stripmap track slot by slot (slots.SlotSchedule), applying P_com[k][n]
in slot n and computing the rate it achieves from where it actually is. Publishes
`uav{K}/pose` (PoseStamped, every tick and at each slot start) and `uav{K}/achieved_rate`
(Float64, bit/s, one message per slot, at the slot start) and, next to it, `uav{K}/offload`
(Float64MultiArray [slot, power_w, energy_used_j, energy_left_j], topics.OFFLOAD_FIELDS):
the power applied in the slot and the energy used and left of E_com^max. The power is the
plan's P_com[k][n] (`offloading: open`, the default) or the closed-loop choice
(`offloading: closed`, offload.ClosedLoopOffload). A new plan re-targets the UAV
without restarting the slot clock, so a planner restart (same latched plan) changes nothing;
a plan on another survey strip (the formation's frame_id, ros/plan_msgs.py) is a new pass:
its own slots from 0, its own pass start, in the strip's frame, each slot's `offload` naming
the strip, and one "strip i of sortie j complete" line when its slots are flown.

How the UAV flies is chosen once at start-up (`flight.choose_flight`): by itself on the
mission clock, or, in MAVLink mode (`mavlink_listen` set, e.g. `udpin:127.0.0.1:14552`), as an
embedded SITL-style vehicle (sysid `mavlink_sysid`, 0 = 2 + uav_id like the bridge's default
target_sysids) that `mavlink_bridge` flies; the agent then reads the vehicle's position
(converted to the track frame with `track_bearing_deg` and `origin_ned_m`, which must match
the bridge's; default N = y, E = x, D = -z) and slot n starts when the vehicle crosses
y = n v_y delta_t. `time_scale`, the position noise and the wind do not apply then.
With `position_source: autopilot` the agent simulates only the payload's link, on the UAV's own
autopilot: it subscribes to `uav{K}/mavlink/pose` (what mavlink_bridge reads from that
autopilot, already in the track frame), runs the slot schedule on those positions as in MAVLink
mode, and republishes each of them, stamp and all, on `uav{K}/pose` when it arrives (and only
then: an autopilot gone silent leaves uav{K}/pose silent, so the planner's lost-UAV watch
sees it). A non-finite pose, or one in another frame than insar_track, is dropped, counted
(`bad_autopilot_poses`) and logged at most once per guard.DROP_LOG_PERIOD_S.
`position_source: autopilot` with `mavlink_listen` is refused.

In both watched modes the slots run on the planner's pass start (`formation/start`, the
instant every bridge sets its vehicle moving; ros/start_msgs.py, for the plan flown): none
before it, whatever the UAV does on its way to its formation point or while it holds there,
then slot n at the first position at or past its line (observed_mission.py). An agent with a
plan and no pass start says so once; one whose UAV has not reached its next line LAG_WARN_S
after the clock put it there says so, with how far it is behind, every LAG_LOG_PERIOD_S
until it does.

Parameters (param_specs/nodes.py, all read-only: a mission is set up once): uav_id, time_scale
(mission seconds per wall second), position_noise_std_m, noise_seed, max_speed_mps,
max_accel_mps2, offloading, position_source, the simulated link's shadowing_std_db,
shadowing_corr_m, small_scale_fading, rician_k_db, fading_seed and the wind's wind_mps,
gust_std_mps, gust_tau_s (AGENT_SPECS, all off by default, so the link is the paper's model),
mavlink_listen, mavlink_sysid, track_bearing_deg, origin_ned_m (MAVLINK_SPECS) and the scenario
parameters of AGENT_SCENARIO_SPECS from params.PARAM_SPECS (P_max and E_max included, for the
closed loop), so one params file serves every node. Invalid values or unknown names log one
line each and exit with code 2; an embedded vehicle whose loop dies makes the agent log why and
exit with code 1.
"""
from __future__ import annotations

import math
import sys
import time

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from std_msgs.msg import Float64, Float64MultiArray, MultiArrayDimension

from uav_insar_planner.evaluate import rate_tolerance_bps
from uav_insar_planner.exit_codes import EXIT_CRASH
from uav_insar_planner.mavlink.guard import DropLog, finite
from uav_insar_planner.param_specs.nodes import AGENT_SCENARIO_SPECS as SCENARIO_SPECS
from uav_insar_planner.param_specs.nodes import AGENT_SPECS, MAVLINK_SPECS
from uav_insar_planner.params import ParamError, params_from_mapping
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.parameters import (
    check_values,
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
from uav_insar_planner.track.pass_clock import PassClock
from uav_insar_sim.flight import choose_flight
from uav_insar_sim.slots import Phase
from uav_insar_sim.vehicle.simulator import SimVehicle

TICK_PERIOD_S = 0.05  # wall clock; the mission clock advances time_scale times faster
# A UAV this late at its next slot line is behind the pass, not merely jittering about it.
LAG_WARN_S = 2.0
LAG_LOG_PERIOD_S = 10.0


class AgentNode(Node):
    """See the module docstring. `problems` is non-empty (nothing created) on bad parameters.

    `vehicle` is the embedded MAVLink vehicle in MAVLink mode, else None;
    `bad_autopilot_poses` counts the autopilot poses dropped (non-finite, other frame)."""

    def __init__(self, node_name: str = "agent", **kwargs):
        super().__init__(node_name, **kwargs)
        self.vehicle: SimVehicle | None = None
        self.flight = None
        self._drops = DropLog()
        self.problems = declare_specs(self, AGENT_SPECS + MAVLINK_SPECS + SCENARIO_SPECS,
                                      read_only=True) + unknown_overrides(self)
        own = spec_values(self, AGENT_SPECS + MAVLINK_SPECS)
        self.problems += check_values(own, AGENT_SPECS + MAVLINK_SPECS)
        try:
            params = params_from_mapping(spec_values(self, SCENARIO_SPECS))
        except ParamError as exc:
            self.problems += exc.problems
        if not self.problems and own["uav_id"] >= params.num_uavs:
            self.problems.append(f"uav_id: value {own['uav_id']!r} is not allowed with "
                                 f"num_uavs {params.num_uavs}; expected 0..{params.num_uavs - 1}")
        if self.problems:
            return
        try:
            ns = topics.swarm_namespace(self.get_namespace(), own["uav_id"])
            self.flight = choose_flight(own, params)
        except ValueError as exc:
            self.problems.append(str(exc))
            return
        guard_sets(self)
        self.vehicle = self.flight.vehicle
        self.mission = self.flight.mission
        self.k = own["uav_id"]
        self._params = params  # the scenario's (a survey strip's slots and station differ)
        self.uav_name = uav_name(self.k)  # the prefix of every log line
        self._announced = False
        self._phase = self.mission.phase
        self._pose_pub = self.create_publisher(PoseStamped, topics.resolve(ns, topics.pose(
            self.k)), topics.DEPTH)
        self._rate_pub = self.create_publisher(Float64, topics.resolve(
            ns, topics.achieved_rate(self.k)), topics.RATE_DEPTH)
        self._offload_pub = self.create_publisher(Float64MultiArray, topics.resolve(
            ns, topics.offload(self.k)), topics.RATE_DEPTH)
        if not self.flight.own_poses:
            # RATE_DEPTH, reliable: a busy executor still sees every position, in order.
            self.create_subscription(PoseStamped, topics.resolve(ns, topics.mavlink_pose(
                self.k)), self._on_autopilot_pose, topics.RATE_DEPTH)
        self.gate = PlanGate(self, self._adopt_plan, f"{self.uav_name}: ",  # one plan at a time
                             topics.flown_plan(self.k), swarm_ns=ns)
        self._starts = (StartFollower(self, ns, lambda: self.gate.current, self._on_pass_start,
                                      f"{self.uav_name}: ") if self.flight.observed else None)
        self._told_no_start = False
        self._leg = None  # the survey strip flown (track/leg.py), None: a single pass
        self._late: list = []  # slots a late pass start found already flown, to report
        self._rate_tol = rate_tolerance_bps(params.rate_min_bps)
        self._lag_logged_at = -LAG_LOG_PERIOD_S
        self.create_timer(TICK_PERIOD_S, self._tick)
        note = self.flight.start()
        if note:
            self.get_logger().info(f"{self.uav_name}: {note}")
        self.get_logger().info(f"{self.uav_name}: waiting for the formation")

    @property
    def bad_autopilot_poses(self) -> int:
        return self._drops.counts.get("autopilot pose", 0)

    def destroy_node(self) -> None:
        if self.flight is not None:
            self.flight.stop()
        super().destroy_node()

    # --- plan ----------------------------------------------------------------------------
    def _adopt_plan(self, formation: Formation, power: PowerSchedule) -> None:
        """A matched, validated pair of the sole planner (ros/plan_gate.py)."""
        n_uavs = len(formation.points)
        if n_uavs <= self.k:  # a plan of a smaller swarm: nothing to fly, the last plan stays
            self.get_logger().error(f"{self.uav_name}: uav_id {self.k} is not in {power.plan_id}"
                                    f", a plan of {n_uavs} UAVs (uav0..uav{n_uavs - 1}); ignored")
            return
        # None: not flown by this plan (single-baseline's U2); the NaN target holds it at home.
        x, y, z = formation.points[self.k] or (float("nan"), 0.0, float("nan"))
        n = power.p_com_w.shape[1]
        powers = [float(v) for v in power.p_com_w[self.k]]
        if formation.leg != self._leg:
            self._new_pass(formation.leg, n)
        elif n != self.mission.params.num_slots and formation.leg is None:
            self.get_logger().warning(f"{self.uav_name}: plan has {n} slots, num_slots is "
                                      f"{self.mission.params.num_slots}; flying the plan's {n}")
        self.flight.set_plan(x, y, z, powers)
        self.get_logger().info(f"{self.uav_name}: flying {power.plan_id}")
        if not self._announced and self.mission.phase is Phase.TRANSIT:
            self._announced = True
            self.get_logger().info(f"{self.uav_name}: plan received, {self.flight.how} to "
                                   f"x={x:.3f} m, z={z:.3f} m for {n} slots")
        if self._starts is not None:
            self._starts.plan_adopted()
            if (self.mission.pass_start_s is None and self.mission.phase is Phase.TRANSIT
                    and not self._told_no_start):
                self._told_no_start = True
                self.get_logger().info(f"{self.uav_name}: no pass start yet: no slot starts "
                                       f"before the planner's {topics.FORMATION_START}")

    def _new_pass(self, leg, n: int) -> None:
        """Another survey strip: a fresh slot schedule (and frame), the strip's own start."""
        if self._leg is not None and not self.mission.phase.over:
            self.get_logger().warning(
                f"{self.uav_name}: {self._leg.describe()} left after "
                f"{len(self.mission.samples)} of {self.mission.num_slots} slots")
        self._leg = leg
        params = self._params if leg is None else self._params.replace(num_slots=n)
        if leg is not None and leg.station_ne_m is not None:  # the link to it, in its frame
            station = leg.station(float(self._params.ground_station[2]))
            params = params.replace(ground_station_m=list(station))
        self.flight.new_pass(leg, params)
        self.mission, self._announced = self.flight.mission, False
        self._phase = self.mission.phase
        self._told_no_start = False
        if leg is not None:
            self.get_logger().info(f"{self.uav_name}: {leg.describe()}: a new pass of {n} "
                                   "slots, from its own start")

    def _on_pass_start(self, wall_time_s: float, label: str, offset_m: float = 0.0) -> None:
        now = time.time()  # (the clock as the bridge flies it: the same rule, the same ramp)
        clock = PassClock.heard(wall_time_s, now, self.mission.params.speed, offset_m)
        if clock.same_start(self.mission.clock):
            return
        late = self.mission.set_pass_start(clock)
        self._late += late
        self.get_logger().info(f"{self.uav_name}: pass start {clock.describe(now)} ({label}): "
                               "slots from then on" + (
                                   f"; {len(late)} slot(s) flown since, from the positions "
                                   "read meanwhile" if late else ""))

    # --- flight --------------------------------------------------------------------------
    def _tick(self) -> None:
        if self.vehicle is not None and self.vehicle.failure is not None:
            self.get_logger().error(f"{self.uav_name}: embedded MAVLink vehicle died: "
                                    f"{self.vehicle.failure}; exiting")
            raise SystemExit(EXIT_CRASH)  # never a zombie agent that flies nothing
        late, self._late = self._late, []
        for sample in late + self.flight.tick():
            self._say_off_speed(sample.slot - 1)
            if self.flight.own_poses:
                self._publish_pose(sample.position)
            self._rate_pub.publish(Float64(data=sample.rate_bps))
            self._publish_offload(sample)
            if sample.margin_bps < -self._rate_tol:
                self.get_logger().warning(f"{self.uav_name}: "
                                          f"{self.mission.miss_reason(sample)}")
        if self.flight.own_poses:
            self._publish_pose(self.mission.actual_position())
        if self.mission.phase != self._phase:
            self._phase = self.mission.phase
            self._log_phase()
        if self._starts is not None:
            self._say_lag()

    def _say_off_speed(self, n: int) -> None:
        """Slot n just ended (the next one started): one line if it was flown off v_y."""
        if not self.flight.observed or n < 0:
            return
        durations = self.mission.durations()
        if n < len(durations) and (n, durations[n]) in self.mission.off_speed():
            planned = self.mission.planned_s[n]
            self.get_logger().warning(
                f"{self.uav_name}: slot {n} took {durations[n]:.2f} s from its line to the "
                f"next, planned {planned:.2f} s: not flown at the planned speed (held, or "
                "catching up); its data is not where the plan put it")

    def _say_lag(self) -> None:
        """A pass start whose line the UAV does not reach is never silent."""
        now = time.monotonic()
        lag = self.mission.lag(time.time())
        if lag is None or lag[1] < LAG_WARN_S or now - self._lag_logged_at < LAG_LOG_PERIOD_S:
            return
        self._lag_logged_at = now
        n, late, to_go = lag
        where = ("no position from the autopilot yet" if math.isnan(to_go) else
                 f"{to_go:.2f} m short of it")
        self.get_logger().warning(f"{self.uav_name}: the pass started at wall clock "
                                  f"{self.mission.pass_start_s:.3f}; slot {n}'s line "
                                  f"(y = {self.mission.slot_line(n):.2f} m) is {late:.1f} s "
                                  f"overdue, {where}")

    def _on_autopilot_pose(self, msg: PoseStamped) -> None:
        """position_source autopilot: validate, feed the schedule, republish as uav{K}/pose."""
        p = msg.pose.position
        position = (p.x, p.y, p.z)
        frame = msg.header.frame_id
        why = (None if frame == topics.FRAME_ID else f"frame_id {frame[:40]!r} (expected "
               f"{topics.FRAME_ID})") or (None if finite(position) else
                                          f"non-finite position {position}")
        if why:
            line = self._drops.drop("autopilot pose", f"{why} on {topics.mavlink_pose(self.k)}")
            if line:
                self.get_logger().warning(f"{self.uav_name}: {line}")
            return
        self.flight.feed(position, msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec)
        out = PoseStamped()
        out.header.stamp = msg.header.stamp  # when the autopilot's position was read
        out.header.frame_id = topics.FRAME_ID
        out.pose.position = msg.pose.position
        out.pose.orientation.w = 1.0
        self._pose_pub.publish(out)

    def _publish_pose(self, position: tuple[float, float, float]) -> None:
        msg = PoseStamped()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = topics.FRAME_ID
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = position
        msg.pose.orientation.w = 1.0
        self._pose_pub.publish(msg)

    def _publish_offload(self, sample) -> None:
        size = len(topics.OFFLOAD_FIELDS)
        msg = Float64MultiArray()
        msg.layout.dim = [MultiArrayDimension(label=",".join(topics.OFFLOAD_FIELDS), size=size,
                                              stride=size)]
        msg.data = [float(sample.slot), sample.power_w, sample.energy_used_j,
                    sample.energy_left_j, float(-1 if self._leg is None else self._leg.strip)]
        self._offload_pub.publish(msg)

    def _log_phase(self) -> None:
        log = self.get_logger()
        if self._phase is Phase.TRACK:
            since = ""
            if self.flight.observed and self.mission.slot_times_s:
                since = (f", {self.mission.slot_times_s[0] - self.mission.pass_start_s:+.2f} s "
                         "from the pass start")
            log.info(f"{self.uav_name}: {self.flight.track_started_text()}{since}")
        elif self._phase is Phase.HOLD:
            log.warning(f"{self.uav_name}: the plan took this UAV out in mid-flight (NaN target): "
                        f"holding position after {len(self.mission.samples)} slots")
        elif self._phase is Phase.IDLE:
            log.info(f"{self.uav_name}: this scheme does not fly {self.uav_name}; holding at home")
        elif self._phase is Phase.DONE:
            samples = self.mission.samples
            met = sum(s.margin_bps >= -self._rate_tol for s in samples)
            worst = min(s.margin_bps for s in samples) / 1e6 if samples else float("nan")
            speed = ""
            if self.flight.observed and (durations := self.mission.durations()):
                off = self.mission.off_speed()
                speed = (f", {len(samples) - len(off)} at the planned speed"
                         + (f" ({len(off)} off it: " + ", ".join(
                             f"slot {n} {d:.2f} s" for n, d in off[:5])
                            + (", ..." if len(off) > 5 else "") + ")" if off else "")
                         + f", slot durations {min(durations):.2f}-{max(durations):.2f} s "
                         f"of {self.mission.params.slot_duration_s:g} s")
            what = "mission" if self._leg is None else self._leg.describe()
            log.info(f"{self.uav_name}: {what} complete: {len(samples)} slots flown{speed}, "
                     f"rate met in {met}, worst margin {worst:+.4g} Mbit/s")


def main(args: list[str] | None = None) -> int:
    """Run one agent until Ctrl-C / SIGTERM; exit code 2 when the parameters are invalid."""
    return run_node(AgentNode, "agent", args)


if __name__ == "__main__":
    sys.exit(main())
