"""The optional readiness-and-arming sequence of one vehicle, the way an operator flies it.

The steps are the autopilot profile's (`autopilots.profiles.AutopilotProfile.arming_steps`).
ArduPilot: wait for position -> GUIDED (confirmed from the heartbeat) -> arm -> NAV_TAKEOFF to the
formation altitude -> wait for the climb; the bridge holds the setpoints back until the
sequence is done. PX4: wait for position -> stream setpoints > 1 s -> OFFBOARD (confirmed) ->
arm (the offboard setpoint is the takeoff).

Contract:
- "wait for position": `WatchedVehicle.position_ready` (LOCAL_POSITION_NED flowing or a
  HOME_POSITION; a 3D fix where GPS_RAW_INT is reported).
- A mode or arm command counts only once a heartbeat received after its ACCEPTED shows the
  state; else it is sent again after CONFIRM_S. A mode the autopilot dropped later (ArduPilot
  accepts GUIDED while booting, then falls back to STABILIZE) sends the sequence back to the
  mode step; a vehicle that disarmed before its takeoff (DISARM_DELAY) back to the arm step.
- FAILED and TEMPORARILY_REJECTED (ArduPilot answers every failed arming check with FAILED,
  with the reason in a STATUSTEXT) are retried every RETRY_S until `readiness_timeout_s` after
  the sequence started; any other refusal (DENIED, UNSUPPORTED, ...) fails at once, and so
  does a command without any COMMAND_ACK after COMMAND_ATTEMPTS tries, COMMAND_TIMEOUT_S apart
  (the confirmation field counts them). IN_PROGRESS waits for the final ACK.
- Every outcome is reported through `emit(level, text)`. A vehicle already armed under our
  control (and airborne, where the sequence takes off) skips the sequence; one already
  airborne skips the takeoff, unless it was seen disarmed during the sequence: a disarmed
  multicopter stands on the ground, whatever its position estimate says (an EKF's height on
  the ground wanders by tenths of a metre with the barometer and the GNSS, past
  `WatchedVehicle.airborne`'s 0.5 m).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from uav_insar_planner.autopilots.profiles import AutopilotProfile
from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.mavlink.supervision import WatchedVehicle

COMMAND_TIMEOUT_S = 1.0
COMMAND_ATTEMPTS = 3
CONFIRM_S = 3.0  # heartbeats come at >= 1 Hz
RETRY_S = 2.0
POSITION_MAX_AGE_S = 2.0
CLIMB_TIMEOUT_EXTRA_S = 20.0
_RETRIED = (MAV.MAV_RESULT_FAILED, MAV.MAV_RESULT_TEMPORARILY_REJECTED)

SendCommand = Callable[[int, Sequence[float], int], None]  # (command, params, confirmation)
Tell = Callable[[str, str], None]  # (level, text): one vehicle's sequence says it


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


def arming_steps(autopilot: AutopilotProfile) -> list[Step]:
    """The steps of `autopilot`'s arming sequence."""
    custom = float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
    flight = autopilot.flight
    commands = {"mode": Step(f"mode {flight.name}", MAV.MAV_CMD_DO_SET_MODE,
                             (custom, *flight.set_params)),
                "arm": Step("arm", MAV.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,)),
                "takeoff": Step("takeoff", MAV.MAV_CMD_NAV_TAKEOFF)}
    return [commands.get(name, Step(name)) for name in autopilot.arming_steps]


class ArmingSequence:
    """The sequence of one vehicle. `start_down()` gives the formation's start D (NED, m),
    read when the takeoff is sent. Not thread-safe (the bridge holds its lock)."""

    def __init__(self, autopilot: AutopilotProfile, vehicle: WatchedVehicle, send: SendCommand,
                 emit: Tell, start_down: Callable[[], float], readiness_timeout_s: float = 120.0):
        self.autopilot = autopilot
        self.vehicle = vehicle
        self.steps = arming_steps(autopilot)
        self._send, self._emit, self._start_down = send, emit, start_down
        self.readiness_timeout_s = readiness_timeout_s
        self.index = 0
        self.sent_at: float | None = None
        self.accepted_at: float | None = None
        self.retry_at: float | None = None
        self.entered_at: float | None = None
        self.attempts = 0
        self.refusals = 0
        self.deadline: float | None = None
        self.waiting_for = ""
        self.climb_target_d: float | None = None
        self.climb_height = 0.0
        self.climb_deadline: float | None = None
        self.failed = ""
        self.seen_disarmed = False  # then it is on the ground: its takeoff is never skipped

    @property
    def active(self) -> bool:
        return not self.failed and self.index < len(self.steps)

    @property
    def current(self) -> str:
        """The name of the step being run ("" when done or failed)."""
        return self.steps[self.index].name if self.active else ""

    def text(self) -> str:
        """"failed: ..." | "done" | the name of the step being run."""
        if self.failed:
            return "failed: " + self.failed
        if self.index >= len(self.steps):
            return "done"
        return self.steps[self.index].name

    def phase(self) -> str:
        """The sequence's part of the UAV's phase (`supervision.phase`): "failed: ...", the
        readiness step ("waiting for position ...", "setting mode GUIDED (now STABILIZE)",
        "prearm: <reason>", "arming", "armed, taking off", "streaming setpoints before
        OFFBOARD"), or "" once done."""
        if self.failed:
            return "failed: " + self.failed
        if not self.active:
            return ""
        v, step = self.vehicle, self.current
        if step == "wait for position":
            return self.waiting_for or "waiting for position"
        if step.startswith("mode"):
            return f"setting mode {step[5:]} (now {v.mode})"
        if step == "arm" and not v.armed:
            return f"prearm: {v.prearm}" if v.prearm else "arming"
        if step == "stream setpoints":
            return f"streaming setpoints before {self.autopilot.flight.name}"
        return "armed, taking off"

    def retry_now(self) -> None:
        """The link came back: resend the current step at once, with fresh retry counts."""
        self.sent_at, self.accepted_at, self.retry_at, self.attempts = None, None, None, 0

    def step(self, now: float) -> None:
        """Move the sequence on (call often while the vehicle is linked)."""
        v = self.vehicle
        if self.deadline is None:
            self.deadline = now + self.readiness_timeout_s
            self.entered_at = now
            if self._already_in_control():
                self.index = len(self.steps)
                self._emit("info", f"sysid {v.sysid} already armed in {v.mode}; arming "
                                   "sequence skipped")
                return
        step = self.steps[self.index]
        self.seen_disarmed = self.seen_disarmed or not v.armed
        if step.name != "climb" and now > self.deadline:
            why = self.waiting_for or v.prearm or step.name
            self._fail(f"not ready after {self.readiness_timeout_s:g} s ({step.name}: {why})")
            return
        if self._regressed(now):
            return
        if step.name == "wait for position":
            self.waiting_for = v.position_ready(now, POSITION_MAX_AGE_S)
            if not self.waiting_for:
                self._advance(now)
            return
        if step.name == "stream setpoints":
            if v.stream_since is not None and \
                    now - v.stream_since > self.autopilot.stream_before_flight_s:
                self._advance(now)
            return
        if step.name == "climb":
            self._step_climb(now)
            return
        if (step.command == MAV.MAV_CMD_NAV_TAKEOFF and self.sent_at is None and v.airborne
                and not self.seen_disarmed):
            self._emit("info", f"sysid {v.sysid} already airborne; no takeoff")
            self._advance(now)
            self._advance(now)  # and no climb to wait for
            return
        if self.accepted_at is not None:
            self._confirm(step, now)
            return
        if self.retry_at is not None:
            if now < self.retry_at:
                return
            self.retry_at = None
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
        if command != step.command or self.sent_at is None or self.accepted_at is not None:
            return
        sysid = self.vehicle.sysid
        if result == MAV.MAV_RESULT_ACCEPTED:
            self._emit("info", f"sysid {sysid} {step.name}: ACCEPTED")
            if step.command == MAV.MAV_CMD_NAV_TAKEOFF:
                self._advance(now)
            else:
                self.accepted_at = now
        elif result == MAV.MAV_RESULT_IN_PROGRESS:
            self.sent_at = now  # keep waiting for the final ACK
        elif result in _RETRIED:
            self.refusals += 1
            self.sent_at, self.attempts, self.retry_at = None, 0, now + RETRY_S
            if self.refusals == 1 or self.refusals % 10 == 0:
                reason = f" ({self.vehicle.prearm})" if self.vehicle.prearm else ""
                self._emit("warn", f"sysid {sysid} {step.name}: {result_name(result)}{reason}; "
                                   f"retrying every {RETRY_S:g} s until ready "
                                   f"(refusal {self.refusals})")
        else:
            self._fail(f"{step.name}: {result_name(result)}")

    # ------------------------------------------------------------------ internals
    def _in_mode(self) -> bool:
        return self.autopilot.flight.shown_by(self.vehicle.custom_mode)

    def _heard_since(self, t: float | None) -> bool:
        """A heartbeat arrived after time `t` (so it shows the state after that moment)."""
        last = self.vehicle.last_heartbeat
        return t is not None and last is not None and last > t

    def _confirm(self, step: Step, now: float) -> None:
        ok = self.vehicle.armed if step.name == "arm" else self._in_mode()
        if self._heard_since(self.accepted_at) and ok:
            self._advance(now)
        elif now - self.accepted_at > CONFIRM_S:
            self._emit("warn", f"sysid {self.vehicle.sysid} {step.name}: ACCEPTED but the "
                               f"heartbeat still says {self.vehicle.mode}, "
                               f"{'armed' if self.vehicle.armed else 'disarmed'}; again")
            self.accepted_at, self.sent_at, self.attempts = None, None, 0

    def _regressed(self, now: float) -> bool:
        """Go back a step when the heartbeat shows the autopilot undid one; True if so."""
        names = [s.name for s in self.steps]
        mode_index = next(i for i, n in enumerate(names) if n.startswith("mode"))
        step = self.steps[self.index].name
        v = self.vehicle
        if step in ("arm", "takeoff") and self._heard_since(self.entered_at) \
                and not self._in_mode() and not (step == "arm" and self.accepted_at):
            self._emit("warn", f"sysid {v.sysid}: mode is {v.mode}, not {names[mode_index][5:]}"
                               f" any more; setting it again")
            self._go_to(mode_index, now)
            return True
        if step == "takeoff" and self._heard_since(self.entered_at) and not v.armed:
            self._emit("warn", f"sysid {v.sysid} disarmed before its takeoff; arming again")
            self._go_to(names.index("arm"), now)
            return True
        return False

    def _already_in_control(self) -> bool:
        v = self.vehicle
        return v.armed and self._in_mode() and (v.airborne or not self.autopilot.takes_off)

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
            self._advance(now)
        elif now > self.climb_deadline:
            self._emit("warn", f"sysid {v.sysid}: takeoff altitude not confirmed by "
                               "LOCAL_POSITION_NED; streaming setpoints anyway")
            self._advance(now)

    def _go_to(self, index: int, now: float) -> None:
        self.index, self.entered_at = index, now
        self.sent_at, self.accepted_at, self.retry_at = None, None, None
        self.attempts = self.refusals = 0

    def _advance(self, now: float) -> None:
        self._go_to(self.index + 1, now)
        if self.index >= len(self.steps):
            self._emit("info", f"sysid {self.vehicle.sysid}: armed and under our control")

    def _fail(self, why: str) -> None:
        self.failed = why
        self._emit("error", f"sysid {self.vehicle.sysid}: {why}")
