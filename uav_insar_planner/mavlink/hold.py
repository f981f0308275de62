"""Mode orders: MAV_CMD_DO_SET_MODE into one mode, for the UAVs an order is engaged for.

`HoldOrder` is each vehicle's position-hold mode: ArduCopter LOITER (custom_mode 5), PX4
AUTO.LOITER ("HOLD": main 4, sub 3). The bridge engages it when the planner publishes a
formation with every pose NaN (the mission cannot continue, `replanning.plans`) and when the
ground station falls silent for `gcs_timeout_s` (`holding`); it then sends no setpoints.
`ResumeOrder` is the mode the bridge flies in, GUIDED / OFFBOARD: `holding` engages it for a
vehicle the ground-silence hold put in LOITER once a new plan gives it a target again.

An engaged order is sent again every RESEND_S until a vehicle heartbeat that came after the
engagement shows the mode (an older one may predate a hold order still in flight),
at most ATTEMPTS times per vehicle and engagement; a vehicle that is not linked gets it when
it comes back. Once a vehicle showed the mode the order is done for it: a pilot who switches
it to another mode afterwards is not fought. PX4 leaves OFFBOARD at once without a setpoint
stream, so ResumeOrder waits until the bridge has streamed for PX4_STREAM_BEFORE_OFFBOARD_S.
"""
from __future__ import annotations

from collections.abc import Iterable

from uav_insar_planner.mavlink.autopilots import (
    COPTER_MODES,
    PX4_MAIN_MODE_MASK,
    PX4_MODES,
    px4_custom_mode,
)
from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.mavlink.sequencer import PX4_STREAM_BEFORE_OFFBOARD_S
from uav_insar_planner.mavlink.supervision import WatchedVehicle

RESEND_S = 1.0
ATTEMPTS = 5
_ALL_BITS = 0xFFFFFFFF


class ModeOrder:
    """DO_SET_MODE into `mode_name` (HEARTBEAT custom_mode `custom_mode`, compared under
    `mask`) with command params `params`; see the module doc. Not thread-safe (the bridge's
    lock)."""

    def __init__(self, mode_name: str, custom_mode: int, params: tuple[float, ...],
                 mask: int = _ALL_BITS, stream_first_s: float = 0.0):
        self.mode_name, self.custom_mode, self.params = mode_name, custom_mode, params
        self.command = MAV.MAV_CMD_DO_SET_MODE
        self._mask, self._stream_first_s = mask, stream_first_s
        # engaged uav -> (attempts, last time sent, engaged at: None until the first `due`)
        self._sent: dict[int, tuple[int, float, float | None]] = {}
        self._done: set[int] = set()  # engaged uavs that showed the mode

    @property
    def active(self) -> bool:
        return bool(self._sent)

    def engaged(self, uav: int) -> bool:
        return uav in self._sent

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
        return (v.custom_mode & self._mask) == (self.custom_mode & self._mask)

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


class HoldOrder(ModeOrder):
    """Into the position-hold mode of `autopilot` ("ardupilot" | "px4")."""

    def __init__(self, autopilot: str):
        custom = float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
        if autopilot == "px4":
            main, sub = PX4_MODES["HOLD"]
            super().__init__("AUTO.LOITER", px4_custom_mode("HOLD"),
                             (custom, float(main), float(sub)))
        else:
            super().__init__("LOITER", COPTER_MODES["LOITER"],
                             (custom, float(COPTER_MODES["LOITER"])))


class ResumeOrder(ModeOrder):
    """Back into the mode the bridge flies `autopilot` in: GUIDED / OFFBOARD (after a
    setpoint stream, see the module doc)."""

    def __init__(self, autopilot: str):
        custom = float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
        if autopilot == "px4":
            main = PX4_MODES["OFFBOARD"][0]
            super().__init__("OFFBOARD", px4_custom_mode("OFFBOARD"),
                             (custom, float(main), 0.0), mask=PX4_MAIN_MODE_MASK,
                             stream_first_s=PX4_STREAM_BEFORE_OFFBOARD_S)
        else:
            super().__init__("GUIDED", COPTER_MODES["GUIDED"],
                             (custom, float(COPTER_MODES["GUIDED"])))
