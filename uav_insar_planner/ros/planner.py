"""The planner node (`ros2 run uav_insar_planner planner`): solve, publish, watch the agents.

Parameters: every entry of `params.PARAM_SPECS` (config/params.yaml), validated as a whole by
`params_from_mapping` before anything is published. A bad value or an unknown name at start
logs one line per problem and exits with code 2; a run-time set is validated in the on-set
callback (refused with the same lines, nothing changes) and solved after it took effect.

Publishes (names relative to the node's namespace, except /diagnostics):
  formation         geometry_msgs/PoseArray, reliable + transient_local, depth 1: one pose
                    per UAV of the plan (num_uavs, 2..10; NaN for a UAV not flown)
  formation/power   std_msgs/Float64MultiArray, reliable + transient_local, depth 1, one row
                    of P_com per UAV of the plan; both
                    carry the plan's identity (ros/plan_msgs.py)
  formation/markers        visualization_msgs/MarkerArray, latched: the plan (ros/markers.py)
  formation/markers/flown  visualization_msgs/MarkerArray: the agents' positions and paths
  gcs/heartbeat     std_msgs/Header, best effort, every 0.1 s (ros/gcs_link.py): the ground
                    station is alive, and the plan it flies (frame_id: the plan's label); a
                    bridge with gcs_timeout_s holds without it
  /diagnostics      diagnostic_msgs/DiagnosticArray: the plan (OK / ERROR), other planners on
                    `formation` (ERROR, ros/plan_watch.py), the swarm (`planner: swarm`,
                    ros/swarm_watch.py) and, once a second, each UAV's rate margin, position
                    error and the plan it flies (WARN when it misses R_min or flies another
                    plan), with or without a plan of this planner's
Subscribes, for K = 0..num_uavs-1 of the scenario (more when a larger num_uavs is set),
uav{K}/pose (PoseStamped), uav{K}/achieved_rate (Float64, bit/s), uav{K}/plan; the
swarm watch (swarm_watch.py: lost UAVs, saturated closed loops, the re-plans they call for)
also uav{K}/offload and /diagnostics; the pass start (formation_start.py) uav{K}/mavlink/pose, and
publishes formation/start (std_msgs/Header, latched: the wall-clock start of the pass and the
plan it starts) once every flown UAV is captured. Planner-only parameters: uav_timeout_s,
capture_radius_m, start_delay_s (param_specs.nodes.PLANNER_SPECS).
Service ~/replan (std_srvs/Trigger): solve again with the current parameters.
With `survey_file` (planner-only, read once at start: a file that cannot be read, or a survey
at another speed than speed_mps, is one line and exit code 2) the plan is flown strip after
strip (ros/survey_run.py): each publication names its strip in the formation's frame_id,
`planner: survey` is on /diagnostics, and service ~/next_sortie (std_srvs/Trigger) lets the
next sortie go (without survey_file it refuses, saying so).
Solves run on a worker thread (solve_worker), so the node keeps serving while one runs; a
worker that dies turns the plan status ERROR ("solve worker died: ...") and the node exits
with code 1 after publishing it (exit_codes.EXIT_CRASH).
"""
from __future__ import annotations

import sys
import threading

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseArray, PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Float64, Float64MultiArray
from std_srvs.srv import Trigger

from uav_insar_planner import published
from uav_insar_planner.exit_codes import EXIT_CRASH
from uav_insar_planner.extras import SOLVER_MODULES, missing_line
from uav_insar_planner.param_specs.nodes import PLANNER_SPECS
from uav_insar_planner.params import (
    PARAM_SPECS,
    SPEC_BY_NAME,
    ParamError,
    Params,
    params_from_mapping,
)
from uav_insar_planner.plan import Plan
from uav_insar_planner.ros import plan_msgs, topics
from uav_insar_planner.ros.formation_start import FormationStart
from uav_insar_planner.ros.gcs_link import GcsHeartbeat
from uav_insar_planner.ros.markers import PlannerMarkers
from uav_insar_planner.ros.parameters import (
    declare_specs,
    guard_sets,
    shown,
    spec_values,
    unknown_overrides,
)
from uav_insar_planner.ros.plan_msgs import PlanId
from uav_insar_planner.ros.plan_watch import PlanWatch
from uav_insar_planner.ros.run import run_node
from uav_insar_planner.ros.solve_worker import SolveWorker
from uav_insar_planner.ros.survey_run import SurveyRun, survey_for
from uav_insar_planner.ros.swarm_watch import SwarmWatch
from uav_insar_planner.solver import solve

DIAGNOSTICS_PERIOD_S = 1.0


class PlannerNode(Node):
    """See the module docstring. `problems` is non-empty (and nothing was created) when the
    start-up parameters are invalid."""

    def __init__(self, node_name: str = "planner", **kwargs):
        super().__init__(node_name, **kwargs)
        self.problems = declare_specs(self, PARAM_SPECS) + declare_specs(self, PLANNER_SPECS)
        self.problems += unknown_overrides(self)
        params = survey = None
        try:
            params = params_from_mapping(spec_values(self, PARAM_SPECS))
        except ParamError as exc:
            self.problems += exc.problems
        if not self.problems and (path := self.get_parameter("survey_file").value):
            try:
                survey = survey_for(path, params)
            except ValueError as exc:
                self.problems.append(str(exc))
        if self.problems:
            return
        self._state_lock = threading.Lock()
        self._plan: Plan | None = None  # the last published (feasible) plan
        self._plan_status: published.Status | None = None
        self._scenario: Params = params
        self._watched = 0  # UAVs 0.._watched - 1 have their per-UAV subscriptions
        self._reports: list[published.UavReport] = []

        self._formation_pub = self.create_publisher(PoseArray, topics.FORMATION,
                                                    topics.LATCHED)
        self._power_pub = self.create_publisher(Float64MultiArray, topics.POWER, topics.LATCHED)
        self._diag_pub = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS,
                                               topics.DEPTH)
        self._plan_id: PlanId | None = None  # the identity _plan was published under
        self._plans = PlanWatch(self)  # other planners, the plan each agent flies
        self._markers = PlannerMarkers(self)
        self._heartbeat = GcsHeartbeat(self, self._published_plan)
        self.create_service(Trigger, topics.REPLAN, self._on_replan)
        self.create_service(Trigger, topics.NEXT_SORTIE, self._on_next_sortie)
        self._pending: tuple[Params, str] | None = None
        guard_sets(self)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._after_set_parameters)
        self.create_timer(DIAGNOSTICS_PERIOD_S, self._on_diagnostics_timer)
        self._worker = SolveWorker(solve, self._on_solved)
        self._swarm = SwarmWatch(self, params, self._publish_replan, self._set_plan_status)
        self._formation_start = FormationStart(self, self._swarm.lost_uavs,
                                               self._swarm.declare_lost)
        self._survey = (None if survey is None else SurveyRun(
            self, survey, self._republish, self._formation_start.clock, self._swarm.lost_uavs))
        self._watch_uavs(params.num_uavs)
        self._worker.request(params, "start")

    def _watch_uavs(self, n: int) -> None:
        """Subscribe the per-UAV topics of UAVs 0..n-1 not yet watched: the scenario's
        num_uavs at start, more when a larger num_uavs is set at run time. A smaller one keeps
        the others subscribed (rclpy cannot take a subscription back from a callback safely);
        what they say beyond the scenario's UAVs is not reported."""
        for k in range(self._watched, n):
            self.create_subscription(PoseStamped, topics.pose(k),
                                     lambda msg, k=k: self._on_pose(k, msg), topics.DEPTH)
            self.create_subscription(Float64, topics.achieved_rate(k),
                                     lambda msg, k=k: self._on_rate(k, msg), topics.RATE_DEPTH)
            self._plans.watch_uav(k)
            self._swarm.watch_uav(k)
            self._formation_start.watch_uav(k)
        with self._state_lock:
            self._watched = max(self._watched, n)
            self._reports += [published.UavReport()
                              for _ in range(self._watched - len(self._reports))]

    def _fresh_reports(self) -> list[published.UavReport]:
        """What was heard since the plan: nothing yet (call with the state lock held)."""
        return [published.UavReport() for _ in range(self._watched)]

    def stop(self) -> None:
        """Stop the solve worker (call before destroy_node)."""
        if not self.problems:
            self._worker.stop()
            self._swarm.stop()

    # --- parameters and replanning -------------------------------------------------------
    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        """Validate the whole scenario with the changes; nothing changes yet."""
        changes = {p.name: p.value for p in parameters if p.name in SPEC_BY_NAME}
        if not changes:
            return SetParametersResult(successful=True)
        try:
            params = params_from_mapping(spec_values(self, PARAM_SPECS, changes))
        except ParamError as exc:
            reason = "; ".join(exc.problems)
            self.get_logger().warning(f"parameter set refused: {reason}")
            return SetParametersResult(successful=False, reason=reason)
        described = ", ".join(f"{name} {shown(self.get_parameter(name).value)} -> "
                              f"{shown(value)}" for name, value in sorted(changes.items()))
        with self._state_lock:
            self._pending = (params, described)
        return SetParametersResult(successful=True)

    def _after_set_parameters(self, parameters: list[Parameter]) -> None:
        """The set took effect: adopt the scenario and solve it."""
        with self._state_lock:
            pending, self._pending = self._pending, None
            if pending is not None:
                self._scenario = pending[0]
        if pending is not None:
            self._watch_uavs(pending[0].num_uavs)
            self.get_logger().info(f"parameters set: {pending[1]}; solving again")
            self._worker.request(pending[0], "parameters set: " + pending[1])

    def _on_replan(self, request, response):
        with self._state_lock:
            params = self._scenario
        started = self._worker.request(params, "replan service")
        response.success = True
        response.message = (f"solving {params.scheme} now" if started else
                            "a solve is running; another follows with the current parameters")
        response.message += "; the result follows on formation and /diagnostics"
        return response

    def _on_next_sortie(self, request, response):
        if self._survey is None:
            response.success, response.message = False, (
                "refused: no survey_file: this planner flies one pass")
        else:
            response.success, response.message = self._survey.next_sortie()
        return response

    def _on_solved(self, params: Params, plan: Plan | None, error: str | None,
                   reason: str) -> None:
        if not rclpy.ok(context=self.context):
            return
        if plan is None:
            status = published.failure_status(params.scheme, error or "unknown error")
            self.get_logger().error(status.message)
        else:
            status = published.plan_status(plan)
            # rclpy ties a severity to each call site: one call per severity.
            if plan.feasible:
                self.get_logger().info(f"{reason}: {status.message}")
            else:
                self.get_logger().error(f"{reason}: {status.message}")
        with self._state_lock:
            self._plan_status = status
            if plan is not None and plan.feasible:
                self._plan = plan
                self._reports = self._fresh_reports()
        if plan is not None and plan.feasible:
            # With a UAV lost, the full plan is not flown: the swarm watch re-plans it (or
            # re-publishes the hold) at once, so a full-swarm plan never reaches the agents.
            if not self._swarm.has_lost():
                self._publish_plan(plan)
            self._swarm.on_plan(plan, params)
        self._publish_diagnostics()

    # --- the swarm watch's re-plans (swarm_watch.py) -------------------------------------
    def _publish_replan(self, plan: Plan, status: published.Status) -> None:
        """Adopt and publish a re-plan (a reduced or power re-plan, or the hold plan)."""
        with self._state_lock:
            self._plan_status = status
            self._plan = plan
            self._reports = self._fresh_reports()
        self._publish_plan(plan)
        self._publish_diagnostics()

    def _set_plan_status(self, status: published.Status) -> None:
        """Report a re-plan that could not be published."""
        with self._state_lock:
            self._plan_status = status
        self._publish_diagnostics()

    # --- publishing ----------------------------------------------------------------------
    def _published_plan(self) -> PlanId | None:
        with self._state_lock:
            return self._plan_id

    def _publish_plan(self, plan: Plan) -> None:
        """Both messages under a new identity (plan_msgs: stamps unique per planner); in a
        survey, on its strip (ros/survey_run.py)."""
        with self._state_lock:
            last = self._plan_id.stamp if self._plan_id else None
            self._plan_id = PlanId(*plan_msgs.next_stamp(
                self.get_clock().now().seconds_nanoseconds(), last),
                self.get_fully_qualified_name())
            plan_id, scenario = self._plan_id, self._scenario
        leg, length_m = None, scenario.speed * scenario.slot_duration_s * scenario.num_slots
        if self._survey is not None:
            leg, plan = self._survey.on_publish(plan, scenario)
            length_m = leg.length_m
        points = published.formation_points(plan)
        msg, power = plan_msgs.encode(points, plan, plan_id, leg)
        self._formation_pub.publish(msg)
        self._power_pub.publish(power)
        self._markers.publish_plan(scenario, plan)
        self._formation_start.on_plan(plan_id, points, scenario.speed, length_m, leg)

    def _republish(self) -> None:
        """The survey flies another strip: the current plan on it."""
        with self._state_lock:
            plan = self._plan
        if plan is not None:
            self._publish_plan(plan)

    def _on_diagnostics_timer(self) -> None:
        self._publish_diagnostics()
        failure = self._worker.failure or self._swarm.failure
        if failure is not None:  # said ERROR: now leave, never a zombie
            self.get_logger().error("solve worker died: " + failure)
            raise SystemExit(EXIT_CRASH)

    def _publish_diagnostics(self) -> None:
        with self._state_lock:
            failure = self._worker.failure or self._swarm.failure
            if failure is not None:  # no more plans will come: say so
                self._plan_status = published.failure_status(
                    self._scenario.scheme, "solve worker died: " + failure)
            statuses = [self._plan_status] if self._plan_status else []
            statuses.append(self._swarm.status())
            if self._survey is not None:
                statuses.append(self._survey.status())
            # Per-UAV status even without a plan of this planner's (restarted infeasible).
            statuses += self._plans.statuses(self._plan, self._plan_id,
                                             self._scenario.rate_min_bps, self._reports)
        if not statuses:
            return
        msg = DiagnosticArray()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.status = [
            DiagnosticStatus(level=getattr(DiagnosticStatus, published.LEVEL_NAMES[s.level]),
                             name=s.name, message=s.message, hardware_id=s.hardware_id,
                             values=[KeyValue(key=key, value=v) for key, v in s.values])
            for s in statuses]
        self._diag_pub.publish(msg)

    # --- agent reports -------------------------------------------------------------------
    def _on_pose(self, k: int, msg) -> None:
        p = msg.pose.position
        with self._state_lock:
            if k < len(self._reports):
                self._reports[k].position = (p.x, p.y, p.z)
        self._swarm.on_pose(k, msg)
        self._markers.on_pose(k, msg)

    def _on_rate(self, k: int, msg) -> None:
        with self._state_lock:
            rate_min = self._scenario.rate_min_bps
            if k < min(len(rate_min), len(self._reports)):  # a UAV of the scenario
                self._reports[k].record_rate(msg.data, rate_min[k])
        self._swarm.on_rate(k, msg)


def main(args: list[str] | None = None) -> int:
    """Run the planner until Ctrl-C / SIGTERM; exit code 2 when the parameters are invalid, 1
    on an install without the solvers (extras.py)."""
    if line := missing_line(SOLVER_MODULES):
        print(f"[ERROR] [planner]: {line}", file=sys.stderr, flush=True)
        return EXIT_CRASH
    return run_node(PlannerNode, "planner", args)


if __name__ == "__main__":
    sys.exit(main())
