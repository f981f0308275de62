"""MAV_CMD_MISSION_START to every vehicle at one instant, each over its own link: how PX4 UAVs
flying `uav-insar export-mission`'s files start their passes together (`uav-insar
start-missions`, cli/start_missions.py).

PX4 ignores NAV_DELAY's UTC hour, minute and second (its navigator keeps param1 only, as a
hold time clamped to 0), so its files hold at the pass start (LOITER_UNLIM) instead, and
MISSION_START with param1 = the pass's first item moves each on: PX4's commander switches to
AUTO.MISSION (arming is a no-op in the air) and its navigator sets the current item to param1.

`start_missions` listens on every link until the instant (sending a GCS HEARTBEAT each
HEARTBEAT_PERIOD_S, so a udpout peer learns where to answer), takes each link's vehicle from
its first autopilot HEARTBEAT (not a GCS's), and at the instant:
- if any vehicle was not heard within HEARD_WITHIN_S, sends nothing (a swarm started without
  one of its UAVs flies baselines nobody planned; the others keep holding);
- else sends COMMAND_LONG MISSION_START on every link, back to back, and waits for each
  COMMAND_ACK; a vehicle silent for ACK_TIMEOUT_S gets it again (confirmation + 1), at most
  TRIES times in all; MAV_RESULT_IN_PROGRESS waits on.
"""
from __future__ import annotations

import select
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from uav_insar_planner.mavlink.link import MAV, Link

HEARTBEAT_PERIOD_S = 1.0
HEARD_WITHIN_S = 3.0  # a vehicle silent longer than this at the instant is not started
ACK_TIMEOUT_S = 1.0
TRIES = 3
_SPIN_S = 0.002  # the last moments before the instant are spun, not slept, for accuracy


@dataclass
class Outcome:
    """What one link's vehicle did: `result` is the MAV_RESULT of its COMMAND_ACK (None: not
    sent, or no ACK); times are UTC seconds (time.time())."""

    address: str
    sysid: int | None = None
    compid: int = 0
    heard_at: float | None = None
    sent_at: list[float] = field(default_factory=list)
    result: int | None = None
    acked_at: float | None = None

    @property
    def accepted(self) -> bool:
        return self.result == MAV.MAV_RESULT_ACCEPTED

    def describe(self, instant: float) -> str:
        """One line: what happened, and when, against the instant."""
        who = f"{self.address} (sysid {self.sysid})" if self.sysid else self.address
        if not self.sent_at:
            return (f"{who}: last HEARTBEAT {self.heard_at - instant:+.3f} s, nothing sent"
                    if self.heard_at is not None else f"{who}: no autopilot HEARTBEAT")
        sent = f"sent {self.sent_at[0] - instant:+.3f} s"
        if len(self.sent_at) > 1:
            sent += f" ({len(self.sent_at)} tries)"
        if self.result is None:
            return f"{who}: {sent}, no COMMAND_ACK"
        name = MAV.enums["MAV_RESULT"][self.result].name if self.result in \
            MAV.enums["MAV_RESULT"] else str(self.result)
        return f"{who}: {sent}, {name} {self.acked_at - instant:+.3f} s"


def autopilot_heartbeat(msg) -> bool:
    """Whether `msg` is an autopilot's HEARTBEAT (not a ground station's)."""
    return (msg.get_type() == "HEARTBEAT" and msg.type != MAV.MAV_TYPE_GCS
            and msg.autopilot != MAV.MAV_AUTOPILOT_INVALID)


class _Session:
    """The links and what each vehicle said; one thread."""

    def __init__(self, links: Sequence[Link], clock: Callable[[], float]):
        self.links = list(links)
        self.outcomes = [Outcome(link.address) for link in self.links]
        self.clock = clock
        self._beat = -HEARTBEAT_PERIOD_S

    def wait(self, seconds: float) -> None:
        """Read every link for up to `seconds` (at least once), beating our HEARTBEAT."""
        fds = [fd for link in self.links if (fd := link.fileno()) is not None]
        if seconds > 0:
            if fds and len(fds) == len(self.links):
                select.select(fds, [], [], seconds)
            else:  # a link without a descriptor (TCP reconnecting) is polled
                time.sleep(min(seconds, 0.01))
        now = self.clock()
        if now - self._beat >= HEARTBEAT_PERIOD_S:
            self._beat = now
            for link in self.links:
                link.send(link.mav.heartbeat_encode(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID,
                                                    0, 0, MAV.MAV_STATE_ACTIVE))
        for link, out in zip(self.links, self.outcomes, strict=True):
            for msg in link.poll():
                self._read(msg, out, now)

    def _read(self, msg, out: Outcome, now: float) -> None:
        src = msg.get_srcSystem()
        if autopilot_heartbeat(msg) and out.sysid in (None, src):
            out.sysid, out.compid, out.heard_at = src, msg.get_srcComponent(), now
        elif (msg.get_type() == "COMMAND_ACK" and msg.command == MAV.MAV_CMD_MISSION_START
              and src == out.sysid and out.sent_at and out.result is None
              and msg.result != MAV.MAV_RESULT_IN_PROGRESS):
            out.result, out.acked_at = msg.result, now

    def send(self, i: int, first_item: int) -> None:
        link, out = self.links[i], self.outcomes[i]
        link.send(link.mav.command_long_encode(
            out.sysid, out.compid, MAV.MAV_CMD_MISSION_START, len(out.sent_at),
            float(first_item), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
        out.sent_at.append(self.clock())


def start_missions(links: Sequence[Link], instant: float, first_item: int,
                   clock: Callable[[], float] = time.time) -> list[Outcome]:
    """Start every link's vehicle at `instant` (UTC seconds) from mission item `first_item`;
    one Outcome per link, in order (see the module doc for the rules)."""
    session = _Session(links, clock)
    while (left := instant - clock()) > _SPIN_S:
        session.wait(min(left - _SPIN_S, 0.05))
    while clock() < instant:
        pass
    now = clock()
    if any(o.heard_at is None or now - o.heard_at > HEARD_WITHIN_S for o in session.outcomes):
        return session.outcomes
    for i in range(len(links)):
        session.send(i, first_item)
    while True:
        waiting = [i for i, o in enumerate(session.outcomes) if o.result is None]
        if not waiting:
            break
        now = clock()
        for i in waiting:
            out = session.outcomes[i]
            if now - out.sent_at[-1] >= ACK_TIMEOUT_S and len(out.sent_at) < TRIES:
                session.send(i, first_item)
        if all(clock() - session.outcomes[i].sent_at[-1] >= ACK_TIMEOUT_S
               and len(session.outcomes[i].sent_at) >= TRIES for i in waiting):
            break
        session.wait(0.02)
    return session.outcomes
