"""The planner's watch over the swarm in flight: lost UAVs and saturated closed loops, and the
re-plans they call for (the ROS side of replanning/triggers.py; the mathematics is
replanning/plans.py's).

Created by the planner node, which hands it two callbacks, `publish` (adopt and publish a
re-plan with its status) and `report` (the status of a re-plan not published), and feeds it
uavK/pose and uavK/achieved_rate (`on_pose`, `on_rate`) and every plan it publishes
(`on_plan`); it subscribes uavK/offload and /diagnostics (the MAVLink bridge's
`mavlink_bridge: uavK` statuses with link `lost` or `out_of_control`, a vehicle a failsafe
or a pilot took: `published.bridge_cannot_fly`) itself, and checks the swarm every
CHECK_PERIOD_S against the planner parameter `uav_timeout_s`.

- Lost slave, the plan flew it and at least one slave survives: the (N-1)-UAV problem of
  `plans.remaining_problem` (single-baseline when one slave is left) is solved (on a worker
  thread) from the slot the swarm reached with the energy left; the plan is published on
  formation / formation/power (the lost UAV NaN, its power row zero) with the plan status
  `uavK lost at slot n (why); re-planned from slot n without uavK: ...`; WARN instead of OK
  when a new target lies within plan.SAFE_SEPARATION_M (across-track) of where the lost UAV
  was last heard (the solver knows nothing of it, and a UAV that is only silent may still be
  there). An infeasible reduced problem is reported (ERROR) and not published: the survivors
  fly on with the plan they have.
- Lost master (or no slave left): nothing can be measured any more; the plan status is ERROR
  `mission cannot continue: master uav0 lost at slot n (why)` and the hold plan
  (`plans.hold_plan`: every pose NaN, every power zero) is published: agents hold where
  they are, the bridge commands LOITER.
- Saturated closed loop (`triggers.Saturated`): WARN on the `planner: swarm` status,
  then the power re-plan of `plans.power_replan` for that UAV, formation unchanged.
- A lost UAV heard again: one warning line, and `heard again since, not re-planned` in its
  value of the swarm status; it stays out of the plan (replanning/triggers.py).
- `status()`: the `planner: swarm` status, one value per UAV (heard / not heard / lost).
"""
from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from std_msgs.msg import Float64MultiArray

from uav_insar_planner import published
from uav_insar_planner.params import Params
from uav_insar_planner.plan import SAFE_SEPARATION_M, Plan
from uav_insar_planner.replanning import plans
from uav_insar_planner.replanning.triggers import Lost, ReplanTriggers, Saturated
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.solve_worker import SolveWorker
from uav_insar_planner.swarm import MASTER, uav_name

CHECK_PERIOD_S = 0.1
SWARM_STATUS_NAME = "planner: swarm"


@dataclass(frozen=True)
class LostSlaveReplan:
    """A reduced problem to solve on the worker thread."""

    params: Params
    plan: Plan
    lost: Lost
    survivors: tuple[int, ...]
    energy_left: dict[int, float]


class SwarmWatch:
    """See the module docstring. `node` gives the subscriptions, the timer, the log and the
    `uav_timeout_s` parameter; `publish` and `report` are the planner's."""

    def __init__(self, node: Node, params: Params,
                 publish: Callable[[Plan, published.Status], None],
                 report: Callable[[published.Status], None]) -> None:
        self._node, self._publish, self._report = node, publish, report
        self._lock = threading.Lock()
        self._params = params
        self._plan: Plan | None = None
        self.triggers = ReplanTriggers(params)
        self._ended: str | None = None  # why the mission cannot continue
        self._warnings: list[str] = []
        node.create_subscription(DiagnosticArray, topics.DIAGNOSTICS, self._on_diagnostics,
                                 topics.RATE_DEPTH)
        node.create_timer(CHECK_PERIOD_S, self._check)
        self._worker = SolveWorker(self._solve, self._on_solved)

    def stop(self) -> None:
        self._worker.stop()

    def watch_uav(self, k: int) -> None:
        """Watch UAV k too: its uav{k}/offload and a place in the triggers (the planner calls
        it for each UAV of the scenario, and for more when num_uavs grows)."""
        with self._lock:
            self.triggers.watch(k + 1)
        self._node.create_subscription(Float64MultiArray, topics.offload(k),
                                       lambda msg, k=k: self._on_offload(k, msg),
                                       topics.RATE_DEPTH)

    @property
    def failure(self) -> str | None:
        """Why the re-plan worker died, or None."""
        return self._worker.failure

    # --- inputs ----------------------------------------------------------------------------
    def on_pose(self, k: int, msg: Any) -> None:
        p = msg.pose.position
        with self._lock:
            self.triggers.heard_pose(k, time.monotonic(), (p.x, p.y, p.z))

    def on_rate(self, k: int, msg: Any) -> None:
        with self._lock:
            self.triggers.heard_rate(k, time.monotonic(), msg.data)

    def _on_offload(self, k: int, msg: Any) -> None:
        data = list(msg.data)
        if len(data) != len(topics.OFFLOAD_FIELDS):
            return
        with self._lock:
            self.triggers.heard_offload(k, time.monotonic(), int(data[0]), data[1], data[3])

    def _on_diagnostics(self, msg: Any) -> None:
        for s in msg.status:
            k = published.bridge_status_uav(s.name)
            if k is None:
                continue
            why = published.bridge_cannot_fly({kv.key: kv.value for kv in s.values}, s.message)
            if why and k < len(self.triggers.uavs):
                with self._lock:
                    lost = self.triggers.bridge_lost(k, time.monotonic(), why)
                if lost is not None:
                    self._react(lost)

    def declare_lost(self, k: int, why: str) -> None:
        """UAV k cannot go on with the swarm (`why`: who says so, and why): lost, as by
        silence."""
        with self._lock:
            lost = self.triggers.declared_lost(k, time.monotonic(), why)
        if lost is not None:
            self._react(lost)

    def has_lost(self) -> bool:
        """Whether a UAV of the swarm has been declared lost (final for the mission)."""
        with self._lock:
            return bool(self.triggers.lost)

    def lost_uavs(self) -> set[int]:
        """The UAVs declared lost so far."""
        with self._lock:
            return set(self.triggers.lost)

    def on_plan(self, plan: Plan, params: Params) -> None:
        """A full plan was published: the swarm flies it now (a UAV already lost is taken
        out of it again at once)."""
        with self._lock:
            self._plan, self._params = plan, params
            self.triggers.set_plan(plan.p_com_w, params)
            lost = list(self.triggers.lost.values())
        for item in lost:
            self._react(item, again=True)

    # --- reactions -------------------------------------------------------------------------
    def _check(self) -> None:
        timeout = float(self._node.get_parameter("uav_timeout_s").value)
        with self._lock:
            lost = self.triggers.check(time.monotonic(), timeout)
            saturated = self.triggers.take_saturated()
            back = self.triggers.take_back()
        for item in lost:
            self._react(item)
        for item in back:
            self._node.get_logger().warning(
                f"{uav_name(item.uav)} heard again after it was lost at slot {item.slot}: "
                "not taken back into the plan (lost is final for the mission)")
        for event in saturated:
            self._power_replan(event)

    def _react(self, lost: Lost, again: bool = False) -> None:
        name = uav_name(lost.uav)
        log = self._node.get_logger()
        with self._lock:
            plan, params = self._plan, self._params
        if not again:
            log.warning(f"{name} lost at slot {lost.slot}: {lost.why}")
        if plan is None or lost.uav not in plan.active_uavs:
            return  # not flown by the plan: nothing to re-plan
        survivors = plans.surviving_slaves(plan.active_uavs, lost.uav)
        if lost.uav == MASTER or not survivors:
            who = f"master {name}" if lost.uav == MASTER else f"{name}, the last slave,"
            self._hold(params, lost, f"mission cannot continue: {who} lost at slot "
                                     f"{lost.slot} ({lost.why}); every UAV holds position")
            return
        if lost.slot >= params.num_slots:
            log.info(f"{name} lost after the last slot: nothing left to re-plan")
            return
        with self._lock:
            energy = {k: self.triggers.energy_left_j(k, lost.slot) for k in (MASTER, *survivors)}
        self._worker.request(LostSlaveReplan(params, plan, lost, survivors, energy),
                             f"{name} lost")

    def _hold(self, params: Params, lost: Lost, why: str) -> None:
        with self._lock:
            self._ended = why
        status = published.Status(published.ERROR, published.PLAN_STATUS_NAME, why,
                                  [("lost_uav", uav_name(lost.uav)),
                                   ("lost_at_slot", str(lost.slot))])
        self._node.get_logger().error(why)
        self._publish(plans.hold_plan(params, why), status)

    def _solve(self, request: LostSlaveReplan) -> Plan:
        lost = request.lost
        plan, _ = plans.replan_without(request.params, request.plan.p_com_w, lost.uav,
                                        request.survivors, lost.slot, request.energy_left)
        return plan

    def _on_solved(self, request: LostSlaveReplan, plan: Plan | None, error: str | None,
                   reason: str) -> None:
        lost, log = request.lost, self._node.get_logger()
        head = f"{uav_name(lost.uav)} lost at slot {lost.slot} ({lost.why})"
        if plan is None or not plan.feasible:
            why = error or (published.plan_status(plan).message if plan else "no plan")
            status = published.Status(published.ERROR, published.PLAN_STATUS_NAME,
                                      f"{head}: re-plan failed, flying on with the old plan: {why}")
            log.error(status.message)
            self._report(status)
            return
        status = published.plan_status(plan)
        latency = time.monotonic() - lost.at
        status.message = f"{head}; {plan.message}: {status.message}"
        with self._lock:
            last = self.triggers.uavs[lost.uav].position
        near = self._near_the_lost(plan, lost.uav, last)
        if near:
            status.level = published.WARN
            status.message += "; " + near
        status.values += [("lost_uav", uav_name(lost.uav)), ("lost_at_slot", str(lost.slot)),
                          ("replan_latency_s", published.fmt(latency))]
        with self._lock:
            self._plan = plan
            self.triggers.set_plan(plan.p_com_w)
        self._publish(plan, status)
        log.info(f"{status.message}; published {latency * 1e3:.0f} ms after detection")

    @staticmethod
    def _near_the_lost(plan: Plan, lost: int, last: tuple[float, float, float] | None) -> str:
        """A warning when a new target is within SAFE_SEPARATION_M (across-track) of where the
        lost UAV was last heard: a UAV that is only silent may still be there."""
        if last is None:
            return ""
        close = [(k, math.hypot(plan.formation[k][0] - last[0], plan.formation[k][1] - last[2]))
                 for k in plan.active_uavs]
        close = [(k, d) for k, d in close if d < SAFE_SEPARATION_M]
        return "; ".join(f"{uav_name(k)}'s new target is {d:.2f} m across-track from where "
                         f"{uav_name(lost)} was last heard (it may still be there)"
                         for k, d in close)

    def _power_replan(self, event: Saturated) -> None:
        with self._lock:
            plan, params = self._plan, self._params
        name = uav_name(event.uav)
        cause = "at P_max" if event.at_p_max else "short of energy"
        warning = (f"{name} closed loop saturated: R_min missed {len(event.slots)} slots in a "
                   f"row (slots {event.slots[0]}-{event.slots[-1]}) {cause}")
        log = self._node.get_logger()
        log.warning(warning)
        with self._lock:
            self._warnings.append(warning)
        if plan is None or event.uav not in plan.active_uavs or (
                event.next_slot >= params.num_slots):
            return
        new = plans.power_replan(params, plan, event.uav, event.next_slot,
                                  event.energy_left_j, event.gain)
        status = published.plan_status(new)
        status.message = f"{warning}; {new.message}: {status.message}"
        with self._lock:
            self._plan = new
            self.triggers.set_plan(new.p_com_w)
        self._publish(new, status)
        log.info(status.message)

    # --- the operator's view ---------------------------------------------------------------
    def status(self) -> published.Status:
        """The `planner: swarm` diagnostic status."""
        now = time.monotonic()
        with self._lock:
            m = self.triggers
            values = [(uav_name(k), m.describe(k, now)) for k in range(len(m.uavs))]
            values.append(("next_slot", str(m.next_slot())))
            lost = [f"{uav_name(k)} lost at slot {item.slot}" for k, item in
                    sorted(m.lost.items())]
            heard = [uav_name(k) for k, u in enumerate(m.uavs)
                     if u.last_heard is not None and k not in m.lost]
            ended, warnings = self._ended, list(self._warnings[-3:])
        values.append(("uav_timeout_s", published.fmt(
            float(self._node.get_parameter("uav_timeout_s").value))))
        if ended:
            return published.Status(published.ERROR, SWARM_STATUS_NAME, ended, values)
        if lost or warnings:
            return published.Status(published.WARN, SWARM_STATUS_NAME,
                                    "; ".join(lost + warnings), values)
        if not heard:
            return published.Status(published.STALE, SWARM_STATUS_NAME, "no UAV heard yet",
                                    values)
        return published.Status(published.OK, SWARM_STATUS_NAME, ", ".join(heard) + " heard",
                                values)
