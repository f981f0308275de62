"""One bridge per vehicle on the graph: claims on `uav{K}/mavlink/claim`.

Every MAVLink bridge (a stack per UAV or the all-in-one) publishes, latched, one claim per UAV
it flies: "claim <its fully qualified node name> <sec>.<nanosec>", the wall-clock time it
started. It sends no MAVLink byte before DISCOVERY_WINDOW_S has passed (its links stay silent:
the caller starts the bridge's I/O in `on_granted`); then the oldest claim of each UAV flies:
older = earlier start, ties broken by node name, then the claim text, so that every bridge
reaches the same verdict. A younger claimant is refused with one line naming the UAV and the
other claimant (`on_refused(line)`; the node exits 2). A claim that turns up later and is
older than ours (graphs that joined late, a discovery slower than the window) refuses us then:
the older bridge keeps flying, two never command one vehicle for longer than discovery takes.
A bridge that stops takes its latched claim with it (the DDS writer goes); one killed hard
cannot send it to a bridge started after it died (a latched sample comes from its live
writer), so a restart in its place is granted; a bridge already running keeps the dead
claim until the middleware's liveliness lease runs out. Claims that do not parse are
dropped, counted and logged rate-limited.
"""
from __future__ import annotations

import re
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from rclpy.node import Node
from std_msgs.msg import String

from uav_insar_planner.mavlink.guard import DropLog
from uav_insar_planner.ros import topics
from uav_insar_planner.ros.plan_msgs import DROP_LOG_PERIOD_S, PlanMessageError
from uav_insar_planner.swarm import uav_name

# Fast DDS discovers a new participant on one host in ~0.1-1 s, on a loaded 2-core machine or
# a radio link up to ~2 s; 3 s covers both, and costs 3 s once at start.
DISCOVERY_WINDOW_S = 3.0
_CLAIM = re.compile(r"^claim (/\S*) (\d{1,12})\.(\d{9})$")


@dataclass(frozen=True, order=True)
class Claim:
    """A bridge's claim; ordering = age (the smallest flies)."""

    sec: int
    nanosec: int
    node: str

    @property
    def text(self) -> str:
        return f"claim {self.node} {self.sec}.{self.nanosec:09d}"

    @classmethod
    def parse(cls, text: str, topic: str) -> Claim:
        found = _CLAIM.match(text)
        if found is None:
            raise PlanMessageError(topic, "data", text, "'claim <node> <sec>.<nanosec>'")
        return cls(int(found[2]), int(found[3]), found[1])


def refusal(uav: int, ours: Claim, seen: Iterable[Claim]) -> str | None:
    """The one-line refusal when a claim in `seen` other than ours is older, else None."""
    older = sorted(c for c in seen if c != ours and c < ours)
    if not older:
        return None
    other = older[0]
    return (f"{uav_name(uav)}: refused, already flown by {other.node} (claimed at "
            f"{other.sec}.{other.nanosec:09d}, before this bridge at "
            f"{ours.sec}.{ours.nanosec:09d}); stop it first, or give another uav_id")


class UavClaims:
    """See the module docstring: publishes our claims on `swarm_ns`'s claim topics of `uavs`
    and decides after DISCOVERY_WINDOW_S; `granted` then turns True."""

    def __init__(self, node: Node, swarm_ns: str, uavs: Iterable[int],
                 on_granted: Callable[[], None], on_refused: Callable[[str], None]) -> None:
        sec, nanosec = divmod(time.time_ns(), 1_000_000_000)
        self.ours = Claim(sec, nanosec, node.get_fully_qualified_name())
        self.granted = False
        self._on_granted, self._on_refused = on_granted, on_refused
        self._seen: dict[int, set[Claim]] = {}
        self._drops, self._log = DropLog(DROP_LOG_PERIOD_S), node.get_logger()
        self._pubs = []
        for k in uavs:
            topic = topics.resolve(swarm_ns, topics.mavlink_claim(k))
            self._seen[k] = set()
            pub = node.create_publisher(String, topic, topics.LATCHED)
            pub.publish(String(data=self.ours.text))
            self._pubs.append(pub)
            node.create_subscription(String, topic,
                                     lambda msg, k=k, t=topic: self._on_claim(k, t, msg),
                                     topics.LATCHED)
        self._timer = node.create_timer(DISCOVERY_WINDOW_S, self._decide)

    @property
    def dropped(self) -> int:
        return self._drops.total

    def _on_claim(self, k: int, topic: str, msg: String) -> None:
        try:
            claim = Claim.parse(msg.data, topic)
        except PlanMessageError as exc:
            if (line := self._drops.drop("claim", str(exc))) is not None:
                self._log.warning(line)
            return
        self._seen[k].add(claim)
        if self.granted:  # a late older claim: yield to it
            line = refusal(k, self.ours, [claim])
            if line:
                self._on_refused(line)

    def _decide(self) -> None:
        self._timer.cancel()
        for k, seen in self._seen.items():
            line = refusal(k, self.ours, seen)
            if line:
                self._on_refused(line)
                return
        self.granted = True
        self._on_granted()
