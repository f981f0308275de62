"""The pass start on the wire (`formation/start`, std_msgs/Header, latched) and the bridge's
side of it.

  header.stamp     the instant the pass starts, WALL clock (time.time(), seconds and
                   nanoseconds since the epoch; not ROS time, which may be simulated)
  header.frame_id  the identity label of the plan it starts ("plan /planner <sec>.<ns>",
                   plan_msgs.PlanId), and where the targets wait until the instant, as the
                   along-track distance from the start line (slot 0's): "<label> at
                   <metres> m", less than 0 for a pass from the hover (its run-in before the
                   line, track/passes.py), more for one that resumes mid-track

The planner publishes it (ros/formation_start.py); a re-plan during the pass (same y_start)
publishes the same instant again under the new plan's label. Validated where it enters
(`decode_start`): a label that is no plan identity, nanoseconds >= 1e9, or an instant more than
PLAUSIBLE_S away from this host's clock (an unset clock, 1970) is dropped, counted and logged
rate-limited; nothing changes.

`StartFollower` (a bridge with pass_start "planner") keeps the latest KEPT starts by plan and
hands the flown plan's start to the bridge: a start for a plan not (yet) flown waits until
that plan is adopted (the latched start may overtake the formation, or follow it).
"""
from __future__ import annotations

import math
import re
import time
from collections.abc import Callable

from rclpy.node import Node
from std_msgs.msg import Header

from uav_insar_planner.mavlink.guard import DropLog
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.plan_msgs import DROP_LOG_PERIOD_S, PlanId, PlanMessageError
from uav_insar_planner.track.pass_clock import PassClock

# A day: far beyond any pass and clock offset worth flying with, close enough to catch a host
# whose clock was never set.
PLAUSIBLE_S = 86400.0
KEPT = 8
MAX_OFFSET_M = 1e6  # far beyond any pass (the bridge's origin limit is 1e5 m)
_OFFSET = re.compile(r"^(.*) at (-?\d{1,7}\.\d{3}) m$")


def encode_start(clock: PassClock, plan_id: PlanId) -> Header:
    """The start message of `plan_id` for `clock` (wall clock): stamp its `start_s`, the pass
    then `offset_m` past its start line (less than 0: its run-in before the line)."""
    offset_m = clock.offset_m
    label = plan_id.label if offset_m == 0.0 else f"{plan_id.label} at {offset_m:.3f} m"
    msg = Header(frame_id=label)
    msg.stamp.sec, msg.stamp.nanosec = divmod(round(clock.start_s * 1e9), 1_000_000_000)
    return msg


def decode_start(msg: Header, wall_now: float) -> tuple[PlanId, float, float]:
    """(plan identity, start in wall-clock seconds, along-track offset at it in metres), or
    PlanMessageError (one line)."""
    at = _OFFSET.match(msg.frame_id)
    label, offset = (at[1], float(at[2])) if at else (msg.frame_id, 0.0)
    plan_id = PlanId.from_label(label)
    if plan_id is None:
        raise PlanMessageError(topics.FORMATION_START, "frame_id", msg.frame_id,
                               "a plan identity 'plan <planner> <sec>.<nanosec>', optionally "
                               "followed by ' at <metres> m'")
    if not (math.isfinite(offset) and -MAX_OFFSET_M <= offset <= MAX_OFFSET_M):
        raise PlanMessageError(topics.FORMATION_START, "frame_id offset", offset,
                               f"-{MAX_OFFSET_M:g}..{MAX_OFFSET_M:g} m")
    sec, nanosec = int(msg.stamp.sec), int(msg.stamp.nanosec)
    if not 0 <= nanosec < 1_000_000_000:
        raise PlanMessageError(topics.FORMATION_START, "stamp.nanosec", nanosec,
                               "0..999999999")
    start = sec + nanosec * 1e-9
    if abs(start - wall_now) > PLAUSIBLE_S:
        raise PlanMessageError(topics.FORMATION_START, "stamp", f"{sec}.{nanosec:09d}",
                               f"within {PLAUSIBLE_S:g} s of this host's clock "
                               f"({wall_now:.0f}); is it synchronised?")
    return plan_id, start, offset


class StartFollower:
    """Subscribes `formation/start` of `swarm_ns` and calls `set_start(wall_time_s, label,
    offset_m)`
    for the start of the plan flown (`flown()`, the PlanGate's current), on arrival and on
    `plan_adopted()`. `dropped` counts the messages refused by validation; `on_message(what,
    plan stamp)` hears every valid one (the ground station is there: ros/gcs_link.py)."""

    def __init__(self, node: Node, swarm_ns: str, flown: Callable[[], PlanId | None],
                 set_start: Callable[[float, str, float], None], prefix: str = "",
                 on_message: Callable[[str, tuple[int, int]], None] | None = None) -> None:
        self._flown, self._set_start, self._prefix = flown, set_start, prefix
        self._on_message = on_message
        self._starts: dict[PlanId, tuple[float, float]] = {}
        self._drops, self._log = DropLog(DROP_LOG_PERIOD_S), node.get_logger()
        node.create_subscription(Header, topics.resolve(swarm_ns, topics.FORMATION_START),
                                 self._on_start, topics.LATCHED)

    @property
    def dropped(self) -> int:
        return self._drops.total

    def _on_start(self, msg: Header) -> None:
        try:
            plan_id, start, offset = decode_start(msg, time.time())
        except PlanMessageError as exc:
            if (line := self._drops.drop("start message", str(exc))) is not None:
                self._log.warning(self._prefix + line)
            return
        if self._on_message is not None:
            self._on_message(f"{topics.FORMATION_START} of {plan_id.label}", plan_id.stamp)
        self._starts.pop(plan_id, None)  # (re-inserted: the newest arrival last)
        self._starts[plan_id] = (start, offset)
        while len(self._starts) > KEPT:
            del self._starts[next(iter(self._starts))]  # the oldest arrival
        self.plan_adopted()

    def plan_adopted(self) -> None:
        """The flown plan may have changed: apply its start if one came."""
        plan_id = self._flown()
        if plan_id is not None and plan_id in self._starts:
            start, offset = self._starts[plan_id]
            self._set_start(start, plan_id.label, offset)
