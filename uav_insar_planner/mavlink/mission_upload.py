"""The ground station's side of MAVLink's mission protocol: a mission uploaded to one vehicle and
downloaded again to check it (`uav-insar upload-mission`, cli/upload_mission.py).

`upload_and_check(link, mission)` on an open link (one thread):
1. the vehicle is the first autopilot HEARTBEAT heard on the link within HEARD_WITHIN_S (a
   GCS HEARTBEAT is sent each HEARTBEAT_PERIOD_S meanwhile, so a udpout peer learns where to
   answer); its MAV_AUTOPILOT must be the plan's firmware (a PX4 file's items are numbered
   without ArduPilot's home item: on the other autopilot every item would be one off);
2. upload: MISSION_COUNT, then each item the vehicle asks for, by MISSION_REQUEST_INT or the
   older MISSION_REQUEST (answered with MISSION_ITEM_INT either way, as MAVSDK does: the
   request's kind only says how the vehicle numbers things, and the INT item keeps 1e-7
   degrees), until its MISSION_ACK. A vehicle silent for ITEM_TIMEOUT_S gets our last
   message again (the count, or the item it asked for last), at most TRIES times in all; a
   MISSION_ACK other than MAV_MISSION_ACCEPTED ends the transfer with its name, but for
   INVALID_SEQUENCE before the last item (an item of ours that came late or twice: ArduPilot
   says so and goes on asking, as it did under load in the suite). When only the
   final ACK is lost (or a vehicle answers our repeated last item with an error because it
   has already finished), the check-back decides;
3. check-back: MISSION_REQUEST_LIST, MISSION_REQUEST_INT for each item (MISSION_ITEM answers
   are taken too), each retried as above, then MISSION_ACK ACCEPTED; every item is compared
   with what was sent (`difference`), the first difference named.
Every failure raises TransferFailed with one line; the whole transfer is bounded by
`transfer_limit_s`.
"""
from __future__ import annotations

import math
import select
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from uav_insar_planner.autopilots.profiles import by_mav_autopilot
from uav_insar_planner.mavlink.link import MAV, Link
from uav_insar_planner.mavlink.mission_start import autopilot_heartbeat
from uav_insar_planner.mission_file.plan_items import MissionItem, PlanMission

HEARTBEAT_PERIOD_S = 1.0
HEARD_WITHIN_S = 5.0  # the vehicle's first HEARTBEAT must come within this of the start
ITEM_TIMEOUT_S = 1.0  # a message unanswered this long is sent again
TRIES = 5  # sends of one message, at most
MISSION = 0  # MAV_MISSION_TYPE_MISSION
#: the _INT frames are their plain frames for comparison (a vehicle may answer either)
SAME_FRAME = {5: 0, 6: 3, 11: 10}
PARAM_TOLERANCE = 1e-4  # relative, of params (float32 on the wire; PX4 stores some in radians)
Z_TOLERANCE_M = 0.01
XY_TOLERANCE = 1  # 1e-7 degrees: PX4 stores latitude and longitude as doubles


class TransferFailed(Exception):
    """A one-line reason why a vehicle's mission was not uploaded and checked back."""


def transfer_limit_s(count: int) -> float:
    """The most a whole upload and check-back of `count` items may take."""
    return 10.0 + 2 * count * ITEM_TIMEOUT_S


def _result_name(result: int) -> str:
    entry = MAV.enums["MAV_MISSION_RESULT"].get(result)
    return entry.name if entry is not None else f"MAV_MISSION_RESULT {result}"


class Peer:
    """One link's vehicle: what it said, read in order, and our messages to it."""

    def __init__(self, link: Link, clock: Callable[[], float] = time.monotonic) -> None:
        self.link = link
        self.clock = clock
        self.sysid: int | None = None
        self.compid = 0
        self.autopilot: int | None = None
        self._queue: deque = deque()
        self._beat = -math.inf
        self.deadline = math.inf

    def _read(self, seconds: float) -> None:
        now = self.clock()
        if now - self._beat >= HEARTBEAT_PERIOD_S:
            self._beat = now
            self.link.send(self.link.mav.heartbeat_encode(
                MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, MAV.MAV_STATE_ACTIVE))
        fd = self.link.fileno()
        if seconds > 0:
            if fd is not None:
                select.select([fd], [], [], seconds)
            else:
                time.sleep(min(seconds, 0.01))
        for msg in self.link.poll():
            if self.sysid is None and autopilot_heartbeat(msg):
                self.sysid, self.compid = msg.get_srcSystem(), msg.get_srcComponent()
                self.autopilot = msg.autopilot
            if self.sysid is not None and msg.get_srcSystem() == self.sysid:
                self._queue.append(msg)

    def heard(self, within_s: float) -> bool:
        """Wait up to `within_s` for the vehicle's first autopilot HEARTBEAT."""
        end = self.clock() + within_s
        while self.sysid is None and self.clock() < end:
            self._read(min(0.05, max(0.0, end - self.clock())))
        return self.sysid is not None

    def next(self, kinds: tuple[str, ...], timeout: float):
        """The vehicle's next message of `kinds` (for us, about missions) within `timeout`,
        else None; the others are dropped."""
        end = min(self.clock() + timeout, self.deadline)
        while True:
            while self._queue:
                msg = self._queue.popleft()
                if msg.get_type() in kinds and self._ours(msg):
                    return msg
            left = end - self.clock()
            if left <= 0:
                if self.clock() >= self.deadline:
                    raise TransferFailed("the transfer took longer than its limit")
                return None
            self._read(min(left, 0.05))

    def _ours(self, msg) -> bool:
        if getattr(msg, "mission_type", MISSION) != MISSION:
            return False
        return getattr(msg, "target_system", 0) in (0, self.link.source_system)

    def send(self, msg) -> None:
        self.link.send(msg)

    def ask(self, msg, kinds: tuple[str, ...], what: str):
        """Send `msg` until an answer of `kinds` comes (TRIES times at most); TransferFailed
        saying `what` was not answered."""
        for _ in range(TRIES):
            self.send(msg)
            if (answer := self.next(kinds, ITEM_TIMEOUT_S)) is not None:
                return answer
        raise TransferFailed(f"no answer to {what} after {TRIES} tries "
                             f"{ITEM_TIMEOUT_S:g} s apart")


def item_int(peer: Peer, item: MissionItem):
    """`item` as a MISSION_ITEM_INT to the peer's vehicle."""
    return peer.link.mav.mission_item_int_encode(
        peer.sysid, peer.compid, item.seq, item.frame, item.command, 0, item.autocontinue,
        *item.params, item.x, item.y, item.z, MISSION)


def upload(peer: Peer, items: tuple[MissionItem, ...]) -> str:
    """Send `items`; "" when the vehicle ACCEPTED them, else a note that the final ACK was
    lost (the check-back decides). TransferFailed on a refusal or silence."""
    count = len(items)
    last = peer.link.mav.mission_count_encode(peer.sysid, peer.compid, count, MISSION)
    what, sends, asked, final_repeated = "MISSION_COUNT", 0, -1, False
    kinds = ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK")
    resend = True
    while True:
        if sends >= TRIES:
            if asked == count - 1:
                return f"no MISSION_ACK after the last item, sent {TRIES} times"
            raise TransferFailed(f"no answer to {what} after {TRIES} tries "
                                 f"{ITEM_TIMEOUT_S:g} s apart")
        if resend:
            final_repeated = final_repeated or (sends > 0 and asked == count - 1)
            peer.send(last)
            sends += 1
        resend = True
        msg = peer.next(kinds, ITEM_TIMEOUT_S)
        if msg is None:
            continue
        if msg.get_type() == "MISSION_ACK" and msg.type == MAV.MAV_MISSION_INVALID_SEQUENCE \
                and asked < count - 1:
            # an item of ours that came late or twice (a retry crossed the next request):
            # ArduPilot says so and goes on asking, so we wait for its request, sending nothing
            resend = False
            continue
        if msg.get_type() == "MISSION_ACK":
            if msg.type == MAV.MAV_MISSION_ACCEPTED and asked == count - 1:
                return ""
            if final_repeated:
                return (f"MISSION_ACK {_result_name(msg.type)} to the repeated last item "
                        "(its first ACK lost)")
            if msg.type == MAV.MAV_MISSION_ACCEPTED:
                raise TransferFailed(f"MISSION_ACK ACCEPTED after item {asked} of {count}")
            raise TransferFailed("the vehicle refused the mission: MISSION_ACK "
                                 f"{_result_name(msg.type)}"
                                 + (f" after item {asked}" if asked >= 0 else ""))
        if not 0 <= msg.seq < count:
            raise TransferFailed(f"the vehicle asked for item {msg.seq}; the mission has "
                                 f"{count} (0..{count - 1})")
        asked, what, sends = msg.seq, f"item {msg.seq}", 0
        last = item_int(peer, items[msg.seq])


def _received(msg) -> MissionItem:
    x, y = msg.x, msg.y
    if msg.get_type() == "MISSION_ITEM" and msg.frame != 2:
        x, y = round(x * 1e7), round(y * 1e7)
    return MissionItem(msg.seq, msg.frame, msg.command,
                       (msg.param1, msg.param2, msg.param3, msg.param4), int(x), int(y),
                       msg.z, msg.autocontinue)


def download(peer: Peer) -> list[MissionItem]:
    """The vehicle's mission, item by item; MISSION_ACK ACCEPTED at the end."""
    mav = peer.link.mav
    answer = peer.ask(mav.mission_request_list_encode(peer.sysid, peer.compid, MISSION),
                      ("MISSION_COUNT", "MISSION_ACK"), "MISSION_REQUEST_LIST")
    if answer.get_type() == "MISSION_ACK":
        raise TransferFailed(f"the vehicle refused the download: MISSION_ACK "
                             f"{_result_name(answer.type)}")
    out = []
    for seq in range(answer.count):
        request = mav.mission_request_int_encode(peer.sysid, peer.compid, seq, MISSION)
        for _ in range(TRIES):
            msg = peer.ask(request, ("MISSION_ITEM_INT", "MISSION_ITEM"),
                           f"MISSION_REQUEST_INT {seq} (check-back)")
            if msg.seq == seq:
                break
        else:
            raise TransferFailed(f"the vehicle answered MISSION_REQUEST_INT {seq} with "
                                 "other items")
        out.append(_received(msg))
    peer.send(mav.mission_ack_encode(peer.sysid, peer.compid, MAV.MAV_MISSION_ACCEPTED,
                                     MISSION))
    return out


def _close(a: float, b: float) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= PARAM_TOLERANCE * max(1.0, abs(a))


def difference(sent: MissionItem, got: MissionItem) -> str | None:
    """How item `got` (downloaded) differs from `sent`, or None (floats within tolerance)."""
    checks = [("command", sent.command, got.command, sent.command == got.command),
              ("frame", sent.frame, got.frame,
               SAME_FRAME.get(sent.frame, sent.frame) == SAME_FRAME.get(got.frame, got.frame))]
    checks += [(f"param{i + 1}", a, b, _close(a, b))
               for i, (a, b) in enumerate(zip(sent.params, got.params, strict=True))]
    checks += [("x", sent.x, got.x, abs(sent.x - got.x) <= XY_TOLERANCE),
               ("y", sent.y, got.y, abs(sent.y - got.y) <= XY_TOLERANCE),
               ("z", sent.z, got.z, abs(sent.z - got.z) <= Z_TOLERANCE_M),
               ("autocontinue", sent.autocontinue, got.autocontinue,
                sent.autocontinue == got.autocontinue)]
    for name, a, b, same in checks:
        if not same:
            return f"item {sent.seq} {name}: sent {a:g}, the vehicle holds {b:g}"
    return None


def check_back(peer: Peer, mission: PlanMission) -> None:
    """TransferFailed naming the first item the vehicle holds otherwise than sent (ArduPilot's
    home item is the vehicle's own, not compared)."""
    held = download(peer)
    if len(held) != len(mission.items):
        raise TransferFailed(f"check-back: the vehicle holds {len(held)} items, "
                             f"{len(mission.items)} were sent")
    for sent, got in zip(mission.items, held, strict=True):
        if mission.home_item and sent.seq == 0:
            continue
        if (problem := difference(sent, got)) is not None:
            raise TransferFailed(f"check-back: {problem}")


@dataclass
class Uploaded:
    """A vehicle whose mission was uploaded and checked back."""

    sysid: int
    items: int
    note: str


def upload_and_check(peer: Peer, mission: PlanMission) -> Uploaded:
    """Steps 1-3 of the module doc on `peer`'s link; TransferFailed with one line."""
    if not peer.heard(HEARD_WITHIN_S):
        raise TransferFailed(f"no autopilot HEARTBEAT within {HEARD_WITHIN_S:g} s")
    if peer.autopilot != mission.firmware:
        flavour = by_mav_autopilot(peer.autopilot)
        name = flavour.name if flavour else f"MAV_AUTOPILOT {peer.autopilot}"
        raise TransferFailed(f"a {mission.autopilot} plan (firmwareType {mission.firmware}), "
                             f"but sysid {peer.sysid} is {name}: its items would be numbered "
                             "otherwise")
    peer.deadline = peer.clock() + transfer_limit_s(len(mission.items))
    note = upload(peer, mission.items)
    check_back(peer, mission)
    return Uploaded(peer.sysid, len(mission.items), note)
