"""The optional arm-and-take-off sequence of one vehicle, with COMMAND_ACK checks and retries.

ArduPilot: GUIDED -> arm -> NAV_TAKEOFF to the formation altitude -> wait for the climb; the
bridge holds the setpoints back until the sequence is done. PX4: stream setpoints > 1 s, then
OFFBOARD -> arm (the offboard setpoint is the takeoff).

Each command is sent up to COMMAND_ATTEMPTS times, COMMAND_TIMEOUT_S apart (the confirmation
field counts the retries). TEMPORARILY_REJECTED is retried up to TEMP_REJECT_ATTEMPTS times,
IN_PROGRESS waits for the final ACK, any other refusal fails the sequence. Every outcome is
reported through `emit(level, text)`. A vehicle already armed under our control (and, for
ArduPilot, airborne) skips the sequence; one already airborne skips the takeoff.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from uav_insar_planner.mavlink.autopilots import COPTER_MODES, PX4_MAIN_MODE_MASK, PX4_MODES
from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.mavlink.supervision import WatchedVehicle

COPTER_MODE_GUIDED = COPTER_MODES["GUIDED"]
PX4_MAIN_MODE_OFFBOARD = PX4_MODES["OFFBOARD"][0]
PX4_STREAM_BEFORE_OFFBOARD_S = 1.2  # PX4 wants > 1 s of setpoints; margin for jitter
COMMAND_TIMEOUT_S = 1.0
COMMAND_ATTEMPTS = 3
TEMP_REJECT_ATTEMPTS = 5
CLIMB_TIMEOUT_EXTRA_S = 20.0

SendCommand = Callable[[int, Sequence[float], int], None]  # (command, params, confirmation)
Emit = Callable[[str, str], None]  # (level, text)


def result_name(result: int) -> str:
    """MAV_RESULT number -> its short name (ACCEPTED, DENIED, ...)."""
    entry = MAV.enums["MAV_RESULT"].get(result)
    return entry.name.removeprefix("MAV_RESULT_") if entry else f"RESULT({result})"


def command_name(command: int) -> str:
    """MAV_CMD number -> its short name (COMPONENT_ARM_DISARM, ...)."""
    entry = MAV.enums["MAV_CMD"].get(command)
    return entry.name.removeprefix("MAV_CMD_") if entry else f"CMD({command})"


@dataclass
class Step:
    name: str
    command: int = 0  # 0: a wait step, no command
    params: tuple[float, ...] = ()


def arming_steps(autopilot: str) -> list[Step]:
    """The steps for "ardupilot" or "px4"."""
    arm = Step("arm", MAV.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
    custom = float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
    if autopilot == "px4":
        return [Step("stream setpoints"),
                Step("mode OFFBOARD", MAV.MAV_CMD_DO_SET_MODE,
                     (custom, float(PX4_MAIN_MODE_OFFBOARD), 0.0)),
                arm]
    return [Step("mode GUIDED", MAV.MAV_CMD_DO_SET_MODE, (custom, float(COPTER_MODE_GUIDED))),
            arm,
            Step("takeoff", MAV.MAV_CMD_NAV_TAKEOFF),
            Step("climb")]


class ArmingSequence:
    """The sequence of one vehicle. `start_down()` gives the formation's start D (NED, m),
    read when the takeoff is sent. Not thread-safe (the bridge holds its lock)."""

    def __init__(self, autopilot: str, vehicle: WatchedVehicle, send: SendCommand, emit: Emit,
                 start_down: Callable[[], float]):
        self.autopilot = autopilot
        self.vehicle = vehicle
        self.steps = arming_steps(autopilot)
        self._send, self._emit, self._start_down = send, emit, start_down
        self.index = 0
        self.sent_at: float | None = None
        self.attempts = 0
        self.temp_rejects = 0
        self.climb_target_d: float | None = None
        self.climb_height = 0.0
        self.climb_deadline: float | None = None
        self.failed = ""

    @property
    def active(self) -> bool:
        return not self.failed and self.index < len(self.steps)

    def text(self) -> str:
        """"failed: ..." | "done" | the name of the step being run."""
        if self.failed:
            return "failed: " + self.failed
        if self.index >= len(self.steps):
            return "done"
        return self.steps[self.index].name

    def retry_now(self) -> None:
        """The link came back: resend the current step at once, with fresh retry counts."""
        self.sent_at, self.attempts, self.temp_rejects = None, 0, 0

    def step(self, now: float) -> None:
        """Move the sequence on (call often while the vehicle is linked)."""
        v = self.vehicle
        step = self.steps[self.index]
        if self.index == 0 and self.sent_at is None and self._already_in_control():
            self.index = len(self.steps)
            self._emit("info", f"sysid {v.sysid} already armed in {v.mode}; arming sequence "
                               "skipped")
            return
        if step.name == "stream setpoints":
            if v.stream_since is not None and now - v.stream_since > PX4_STREAM_BEFORE_OFFBOARD_S:
                self._advance()
            return
        if step.name == "climb":
            self._step_climb(now)
            return
        if step.command == MAV.MAV_CMD_NAV_TAKEOFF and self.sent_at is None and v.airborne:
            self._emit("info", f"sysid {v.sysid} already airborne; no takeoff")
            self._advance()
            self._advance()  # and no climb to wait for
            return
        if self.sent_at is None or now - self.sent_at > COMMAND_TIMEOUT_S:
            if self.attempts >= COMMAND_ATTEMPTS:
                self._fail(f"{step.name}: no COMMAND_ACK after {self.attempts} tries")
                return
            if step.command == MAV.MAV_CMD_NAV_TAKEOFF:
                step.params = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, self._takeoff_altitude())
            self._send(step.command, step.params, self.attempts)
            self.sent_at = now
            self.attempts += 1

    def on_ack(self, command: int, result: int, now: float) -> None:
        """A COMMAND_ACK for us while the sequence is active."""
        step = self.steps[self.index]
        if command != step.command or self.sent_at is None:
            return
        sysid = self.vehicle.sysid
        if result == MAV.MAV_RESULT_ACCEPTED:
            self._emit("info", f"sysid {sysid} {step.name}: ACCEPTED")
            self._advance()
        elif result == MAV.MAV_RESULT_IN_PROGRESS:
            self.sent_at = now  # keep waiting for the final ACK
        elif result == MAV.MAV_RESULT_TEMPORARILY_REJECTED and \
                self.temp_rejects < TEMP_REJECT_ATTEMPTS:
            self.temp_rejects += 1
            self.attempts = 0  # a rejection is an answer, not a lost packet: retry after 1 s
            self._emit("warn", f"sysid {sysid} {step.name}: TEMPORARILY_REJECTED, retrying")
        else:
            self._fail(f"{step.name}: {result_name(result)}")

    def _already_in_control(self) -> bool:
        v = self.vehicle
        if self.autopilot == "px4":
            return v.armed and (v.custom_mode & PX4_MAIN_MODE_MASK) == \
                PX4_MAIN_MODE_OFFBOARD << 16
        return v.armed and v.custom_mode == COPTER_MODE_GUIDED and v.airborne

    def _takeoff_altitude(self) -> float:
        """Metres above the current (home) height up to the formation's start height."""
        v = self.vehicle
        start_d = self._start_down()
        home_d = v.position_ned[2] if v.position_ned is not None else 0.0
        self.climb_target_d = start_d
        # ArduPilot refuses takeoff to <= 0 m; a formation below the ground is the plan's
        # problem, so climb to 1 m and let the setpoints bring the vehicle down.
        self.climb_height = max(home_d - start_d, 1.0)
        return self.climb_height

    def _step_climb(self, now: float) -> None:
        v = self.vehicle
        if self.climb_deadline is None:  # a copter climbs at >= 1 m/s (WPNAV_SPEED_UP)
            self.climb_deadline = now + self.climb_height / 1.0 + CLIMB_TIMEOUT_EXTRA_S
        reached = (v.position_ned is not None and self.climb_target_d is not None
                   and v.position_ned[2] <= self.climb_target_d + 1.0)
        if reached:
            self._advance()
        elif now > self.climb_deadline:
            self._emit("warn", f"sysid {v.sysid}: takeoff altitude not confirmed by "
                               "LOCAL_POSITION_NED; streaming setpoints anyway")
            self._advance()

    def _advance(self) -> None:
        self.index += 1
        self.sent_at, self.attempts, self.temp_rejects = None, 0, 0
        if self.index >= len(self.steps):
            self._emit("info", f"sysid {self.vehicle.sysid}: armed and under our control")

    def _fail(self, why: str) -> None:
        self.failed = why
        self._emit("error", f"sysid {self.vehicle.sysid}: {why}")
