"""The simulated vehicle's side of the MAVLink mission protocol: it accepts and stores a plan.

Upload (GCS -> vehicle): MISSION_COUNT, then MISSION_REQUEST_INT for seq 0..count-1, each
answered by a MISSION_ITEM_INT, then MISSION_ACK ACCEPTED; an item out of sequence is asked
for again, a transfer in progress is replaced by a new MISSION_COUNT, and a count of 0 or
MISSION_CLEAR_ALL empties the store (ACK ACCEPTED). Download (MISSION_REQUEST_LIST,
MISSION_REQUEST_INT) returns what is stored. Only MAV_MISSION_TYPE_MISSION is kept; fences
and rally points are ACKed MAV_MISSION_UNSUPPORTED. The vehicle does not fly the mission
(there is no AUTO mode here); `items` is what a test checks. No retransmission timers: a GCS
that loses a message retries itself (MAVSDK and QGroundControl do). With `request_int` False
the vehicle asks for items with the older MISSION_REQUEST instead (as some autopilots do); it
takes MISSION_ITEM_INT answers either way.
"""
from __future__ import annotations

from uav_insar_planner.mavlink.link import MAV

MAX_ITEMS = 1000  # a GCS cannot make the vehicle hold more than this


class MissionStore:
    """The stored mission (a list of MISSION_ITEM_INT messages) and the upload in progress."""

    def __init__(self) -> None:
        self.items: list = []
        self._pending: list | None = None  # the items of an upload in progress
        self._count = 0
        self._peer = (0, 0)
        #: ask for items with MISSION_REQUEST_INT (True) or the older MISSION_REQUEST
        self.request_int = True

    def handle(self, mav, msg) -> list:
        """The replies (encoded messages) to one mission message from the GCS."""
        kind, peer = msg.get_type(), (msg.get_srcSystem(), msg.get_srcComponent())
        mission_type = getattr(msg, "mission_type", MAV.MAV_MISSION_TYPE_MISSION)
        if mission_type != MAV.MAV_MISSION_TYPE_MISSION:
            return [self._ack(mav, peer, MAV.MAV_MISSION_UNSUPPORTED, mission_type)]
        if kind == "MISSION_CLEAR_ALL":
            self.items, self._pending = [], None
            return [self._ack(mav, peer, MAV.MAV_MISSION_ACCEPTED)]
        if kind == "MISSION_COUNT":
            if msg.count > MAX_ITEMS:
                return [self._ack(mav, peer, MAV.MAV_MISSION_NO_SPACE)]
            if msg.count == 0:
                self.items, self._pending = [], None
                return [self._ack(mav, peer, MAV.MAV_MISSION_ACCEPTED)]
            self._pending, self._count, self._peer = [], msg.count, peer
            return [self._request(mav, 0)]
        if kind == "MISSION_ITEM_INT":
            return self._item(mav, msg, peer)
        if kind == "MISSION_REQUEST_LIST":
            return [mav.mission_count_encode(*peer, len(self.items), mission_type)]
        if kind == "MISSION_REQUEST_INT" and 0 <= msg.seq < len(self.items):
            item = self.items[msg.seq]
            item.target_system, item.target_component = peer
            return [item]
        return []

    def _item(self, mav, msg, peer) -> list:
        if self._pending is None or peer != self._peer:
            return [self._ack(mav, peer, MAV.MAV_MISSION_DENIED)]
        if msg.seq != len(self._pending):
            return [self._request(mav, len(self._pending))]
        self._pending.append(msg)
        if len(self._pending) < self._count:
            return [self._request(mav, len(self._pending))]
        self.items, self._pending = self._pending, None
        return [self._ack(mav, peer, MAV.MAV_MISSION_ACCEPTED)]

    def _request(self, mav, seq: int):
        encode = mav.mission_request_int_encode if self.request_int else mav.mission_request_encode
        return encode(*self._peer, seq, MAV.MAV_MISSION_TYPE_MISSION)

    @staticmethod
    def _ack(mav, peer, result: int, mission_type: int = MAV.MAV_MISSION_TYPE_MISSION):
        return mav.mission_ack_encode(*peer, result, mission_type)
