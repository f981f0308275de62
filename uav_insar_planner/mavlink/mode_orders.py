"""Mode orders: MAV_CMD_DO_SET_MODE into one mode, for the UAVs an order is engaged for.

The modes are the autopilot profile's (`autopilots.profiles.AutopilotProfile`). `hold_order`
is each vehicle's position hold (`hold`: ArduCopter LOITER, PX4 AUTO.LOITER). The bridge
engages it when the planner publishes a formation with every pose NaN (the mission cannot
continue, `replanning.plans`) and when the ground station falls silent for `gcs_timeout_s`
(`holds`); it then sends no setpoints. `resume_order` is the mode the bridge flies in
(`flight`: GUIDED / OFFBOARD): `holds` engages it for a vehicle the ground-silence hold put in
its hold mode once a new plan gives it a target again.

An engaged order is sent again every RESEND_S until a vehicle heartbeat that came after the
engagement shows the mode (an older one may predate a hold order still in flight),
at most ATTEMPTS times per vehicle and engagement; a vehicle that is not linked gets it when
it comes back. Once a vehicle showed the mode the order is done for it: a pilot who switches
it to another mode afterwards is not fought. PX4 leaves OFFBOARD at once without a setpoint
stream, so a resume waits until the bridge has streamed for the profile's
`stream_before_flight_s`.
"""
from __future__ import annotations

from collections.abc import Iterable

from uav_insar_planner.autopilots.profiles import AutopilotProfile, Mode
from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.mavlink.supervision import WatchedVehicle

RESEND_S = 1.0
ATTEMPTS = 5


class ModeOrder:
    """DO_SET_MODE into `mode`, once `stream_first_s` of setpoints went out; see the module
    doc. Not thread-safe (the bridge's lock)."""

    def __init__(self, mode: Mode, stream_first_s: float = 0.0):
        self.mode = mode
        self.params = (float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), *mode.set_params)
        self.command = MAV.MAV_CMD_DO_SET_MODE
        self._stream_first_s = stream_first_s
        # engaged uav -> (attempts, last time sent, engaged at: None until the first `due`)
        self._sent: dict[int, tuple[int, float, float | None]] = {}
        self._done: set[int] = set()  # engaged uavs that showed the mode

    @property
    def active(self) -> bool:
        return bool(self._sent)

    def engaged(self, uav: int) -> bool:
        return uav in self._sent

    def settled(self, uav: int) -> bool:
        """Whether engaged `uav` showed the mode since (the order is done: a mode after it is
        a pilot's or the autopilot's, not ours; `control_states`)."""
        return uav in self._done

    def engage(self, uavs: Iterable[int]) -> None:
        """Order `uavs` into the mode (again: fresh attempts)."""
        for uav in uavs:
            self._sent[uav] = (0, -RESEND_S, None)
            self._done.discard(uav)

    def release(self, uavs: Iterable[int] | None = None) -> None:
        """End the order for `uavs` (None: every UAV); their mode stays what it is."""
        for uav in list(self._sent) if uavs is None else uavs:
            self._sent.pop(uav, None)
            self._done.discard(uav)

    def reached(self, v: WatchedVehicle) -> bool:
        """Whether `v`'s latest heartbeat shows the mode."""
        return self.mode.shown_by(v.custom_mode)

    def due(self, v: WatchedVehicle, now: float) -> bool:
        """True when the command should go to `v` now (call `sent` after sending)."""
        if v.uav not in self._sent or v.uav in self._done or not v.linked:
            return False
        attempts, last, engaged = self._sent[v.uav]
        if engaged is None:
            engaged = now
            self._sent[v.uav] = (attempts, last, engaged)
        if self.reached(v) and v.last_heartbeat is not None and v.last_heartbeat > engaged:
            self._done.add(v.uav)
            return False
        if self._stream_first_s and (v.stream_since is None
                                     or now - v.stream_since <= self._stream_first_s):
            return False
        return attempts < ATTEMPTS and now - last >= RESEND_S

    def sent(self, v: WatchedVehicle, now: float) -> None:
        attempts, _, engaged = self._sent.get(v.uav, (0, 0.0, now))
        self._sent[v.uav] = (attempts + 1, now, engaged)


def hold_order(autopilot: AutopilotProfile) -> ModeOrder:
    """Into `autopilot`'s position hold."""
    return ModeOrder(autopilot.hold)


def resume_order(autopilot: AutopilotProfile) -> ModeOrder:
    """Back into the mode the bridge flies `autopilot` in (after a setpoint stream where it
    needs one, see the module doc)."""
    return ModeOrder(autopilot.flight, autopilot.stream_before_flight_s)
