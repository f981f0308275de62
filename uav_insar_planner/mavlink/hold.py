"""The bridge's hold order: every vehicle into its position-hold mode when the mission stops.

The planner publishes a formation with every pose NaN when the mission cannot continue (the
master lost, `replan.hold_plan`). The bridge then stops the setpoints (no target) and sends
each vehicle MAV_CMD_DO_SET_MODE into its hold mode: ArduCopter LOITER (custom_mode 5), PX4
AUTO.LOITER ("HOLD": main 4, sub 3). The command is sent again every RESEND_S until the
vehicle's heartbeat shows the mode, at most ATTEMPTS times per vehicle; a vehicle that is not
linked gets it when it comes back. A later formation with targets ends the order (the
vehicles stay in their hold mode until the pilot or a GCS switches them back to GUIDED /
OFFBOARD).
"""
from __future__ import annotations

from uav_insar_planner.mavlink.autopilots import COPTER_MODES, PX4_MODES, px4_custom_mode
from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.mavlink.supervision import WatchedVehicle

RESEND_S = 1.0
ATTEMPTS = 5


class HoldOrder:
    """Whether and to whom the hold command is due, for `autopilot` ("ardupilot" | "px4")."""

    def __init__(self, autopilot: str):
        custom = float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
        if autopilot == "px4":
            main, sub = PX4_MODES["HOLD"]
            self.mode_name, self.custom_mode = "AUTO.LOITER", px4_custom_mode("HOLD")
            self.params: tuple[float, ...] = (custom, float(main), float(sub))
        else:
            self.mode_name, self.custom_mode = "LOITER", COPTER_MODES["LOITER"]
            self.params = (custom, float(self.custom_mode))
        self.command = MAV.MAV_CMD_DO_SET_MODE
        self.active = False
        self._sent: dict[int, tuple[int, float]] = {}  # uav -> (attempts, last time)

    def engage(self) -> None:
        self.active, self._sent = True, {}

    def release(self) -> None:
        self.active = False

    def due(self, v: WatchedVehicle, now: float) -> bool:
        """True when the hold command should go to `v` now (call `sent` after sending)."""
        if not self.active or not v.linked or v.custom_mode == self.custom_mode:
            return False
        attempts, last = self._sent.get(v.uav, (0, -RESEND_S))
        return attempts < ATTEMPTS and now - last >= RESEND_S

    def sent(self, v: WatchedVehicle, now: float) -> None:
        attempts, _ = self._sent.get(v.uav, (0, 0.0))
        self._sent[v.uav] = (attempts + 1, now)
