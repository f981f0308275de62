"""The swarm's flight as the bridge keeps it: the formation and its pass, who holds, the arming
sequences, the catch-ups after a rejoin and the separation warnings.

No I/O and not thread-safe: the bridge (`bridge.Bridge`) feeds it what it hears and sends the
commands it asks for, under its lock. Each point's detail is in the module named:
- The pass (`track.trajectory`), started by the capture gate or the planner's instant
  (`start_gate`); the setpoint target of each vehicle (`target_to_send`), none where the
  autopilot ignores them (`autopilots.profiles`: `setpoints_in_flight_only`), a held
  vehicle or one catching up gently (`track.catch_up`).
- Holds (`holds`): the planner's mission stop (every pose NaN) and the ground station's
  silence; a held vehicle at most `holds.REJOIN_S` of the pass behind its target rejoins when
  the ground is heard again or a new start or plan comes, one farther behind keeps holding
  and is reported `behind` (under pass_start "capture" a new plan resumes the pass where the
  swarm holds).
- Optional arm_and_takeoff (`sequencer`), one sequence per UAV a plan flies.
- A vehicle that leaves our control (`control_states`: a failsafe, a pilot's mode change, a
  disarm, any mode no order of ours accounts for) once the bridge has it: said once
  (`out of our control: <mode>`, its phase and `out_of_control`), and never fought: no
  setpoints, no mode order, no arming sequence for it again.
- Two planned UAVs closer than `min_separation_m` are warned about
  (`track.formation.separation`).
- A survey (`track.leg`): each strip a pass of its own, in the strip's frame placed on this
  bridge's home (`origin_ned_m`), its length the strip's; after the sortie's last strip has
  been flown and braked (`SurveyLeg.over_at`), every flown vehicle is ordered to return to
  launch and land (the profile's `home` mode; phase `returning`, then `landed` once
  disarmed), whether the planner is heard or not; the next sortie's first plan arms and
  takes off again (arm_and_takeoff).
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import replace

from uav_insar_planner.autopilots.profiles import profile
from uav_insar_planner.mavlink.config import BridgeConfig
from uav_insar_planner.mavlink.control_states import Heard, UavControl
from uav_insar_planner.mavlink.control_states import step as control_step
from uav_insar_planner.mavlink.holds import REJOIN_S, Holding
from uav_insar_planner.mavlink.mode_orders import ModeOrder
from uav_insar_planner.mavlink.report import Emit, VehicleStatus, vehicle_status
from uav_insar_planner.mavlink.sequencer import ArmingSequence
from uav_insar_planner.mavlink.start_gate import (
    capture_start,
    lags,
    planner_start,
    resume_where_held,
)
from uav_insar_planner.mavlink.supervision import WatchedVehicle
from uav_insar_planner.plan import Vec3
from uav_insar_planner.swarm import uav_name
from uav_insar_planner.track.catch_up import CATCH_UP_FROM_M, CatchUp, governed
from uav_insar_planner.track.cross_track import CrossTrack
from uav_insar_planner.track.formation import clean_formation, separation
from uav_insar_planner.track.frame import TrackFrame
from uav_insar_planner.track.leg import SurveyLeg
from uav_insar_planner.track.trajectory import PassTrajectory

SendCommand = Callable[[WatchedVehicle, int, Sequence[float], int], None]


class FlightState:
    """See the module doc. `count` is how many poses a formation is read for; `emit` and
    `send_command` are the bridge's event sink and command sender."""

    def __init__(self, config: BridgeConfig, frame: TrackFrame,
                 vehicles: Sequence[WatchedVehicle], count: int, emit: Emit,
                 send_command: SendCommand):
        self.config, self.frame, self.vehicles = config, frame, tuple(vehicles)
        self.home = frame  # the configured frame: a single pass's, a survey's home
        self.leg: SurveyLeg | None = None  # the survey strip flown
        self.autopilot = profile(config.autopilot)
        self.returning = ModeOrder(self.autopilot.home)
        self._cross_track: dict[int, CrossTrack] = {}
        self._landed: set[int] = set()  # returned vehicles seen disarmed
        self._count, self._emit, self._send_command = count, emit, send_command
        self.pass_ = PassTrajectory(config.speed_mps, config.track_duration_s)
        self._start_label = ""  # the plan whose pass start the track clock is (planner)
        self._catch_up: dict[int, CatchUp] = {}  # vehicles catching up after a rejoin
        self._separation = [""] * count
        self.sequences: dict[int, ArmingSequence] = {}  # per UAV, once arm_and_takeoff ran
        self.holding = Holding(self.autopilot, config.gcs_timeout_s,
                               [v.uav for v in self.vehicles], emit)
        self.control = {v.uav: UavControl() for v in self.vehicles}  # `control_states`

    def set_formation(self, poses: Sequence[Vec3 | None], now: float,
                      leg: SurveyLeg | None = None) -> None:
        """New formation (see `Bridge.set_formation`)."""
        if leg != self.leg:
            self._new_leg(leg)
        clean = clean_formation(poses, self._count)
        flown = self.pass_.formation is not None and any(self.pass_.formation)
        self.holding.on_plan(clean, flown)
        if self.pass_.set_formation(clean):
            self._emit(-1, "info", "new track start: approaching the formation again")
        self._rejoin(now, "a new plan", here=self.config.pass_start != "planner")
        self._separation, warnings = separation(clean, self.config.min_separation_m)
        for text in warnings:
            self._emit(-1, "warn", text)
        if self.config.arm_and_takeoff:
            for v in self.vehicles:
                if (clean[v.uav] is not None and v.uav not in self.sequences
                        and not self.left(v)):  # (never armed again: it is not ours)
                    self.sequences[v.uav] = self._new_sequence(v)

    def _new_leg(self, leg: SurveyLeg | None) -> None:
        """Another strip (or attempt): a pass of its own, in its frame; a new sortie arms and
        takes off again."""
        if leg is None or self.leg is None or leg.sortie != self.leg.sortie:
            self.sequences.clear()
            self.returning.release()
            self._landed.clear()
            # landed and disarmed: ours again once its arming sequence is done (one that
            # left stays out: the planner lost it for the mission)
            self.control = {k: c if c.left else UavControl() for k, c in self.control.items()}
        self.leg = leg
        self.frame = self.home if leg is None else leg.placed(self.home)
        duration = (self.config.track_duration_s if leg is None
                    else leg.duration_s(self.config.speed_mps))
        self.pass_ = PassTrajectory(self.config.speed_mps, duration)
        self._catch_up.clear()
        self._start_label = ""
        if leg is not None:
            self._emit(-1, "info", f"{leg.describe()}: heading "
                                   f"{math.degrees(leg.frame.bearing_rad):.1f} deg, "
                                   f"{leg.length_m:.1f} m; flying to its entries")

    def _sortie_over(self, now: float) -> None:
        """After the sortie's last strip: every flown vehicle returns to launch (once)."""
        clock, leg = self.pass_.clock, self.leg
        if (leg is None or not leg.last or clock is None or self.returning.active
                or now < leg.over_at(clock)):
            return
        flown = [v.uav for v in self.vehicles if self.pass_.start_pose(v.uav) is not None]
        self.returning.engage(flown)
        self._emit(-1, "info", f"{leg.describe()} flown: the sortie is over; "
                               f"{', '.join(uav_name(k) for k in flown)} return to launch "
                               f"({self.autopilot.home.name}) and land")

    def gcs_heard(self, what: str, now: float, heartbeat: bool, newer_plan: bool) -> None:
        """See `Bridge.gcs_heard`. Heard again while the ground flies a plan not adopted here
        (the planner re-planned during the silence, perhaps without a held UAV), the held
        vehicles wait for it: its adoption (`set_formation`) rejoins them, or not."""
        if not self.holding.gcs_heard(what, now, heartbeat):
            return
        if newer_plan:
            self._emit(-1, "info", "the ground station flies a plan not received here yet: "
                                   "the held vehicles wait for it")
        else:
            self._rejoin(now, "the ground station heard again")

    def set_start(self, wall_time_s: float, now: float, label: str, offset_m: float) -> None:
        """pass_start "planner": see `Bridge.set_start`."""
        text = planner_start(self.pass_, wall_time_s, now, time.time(), label, offset_m)
        self._start_label = label if self.pass_.formation is not None else ""
        if text:  # held ones near their targets rejoin, ones too late to keep up hold
            self._emit(-1, "info", text)
            self._rejoin(now, "a new pass start", late=True)

    def running(self, v: WatchedVehicle) -> ArmingSequence | None:
        """`v`'s arming sequence while it runs."""
        seq = self.sequences.get(v.uav)
        return seq if seq is not None and seq.active else None

    def check(self, now: float) -> None:
        """The clock moved on: the ground's silence, the arming sequences, a sortie's end."""
        self.holding.check(now)
        self._sortie_over(now)
        self._watch_control()
        for v in self.vehicles:
            if self.returning.engaged(v.uav) and not v.armed and v.uav not in self._landed:
                self._landed.add(v.uav)
                self._emit(v.uav, "info", f"sysid {v.sysid} landed and disarmed: ready for the "
                                          "next sortie")
        for v in self.vehicles:
            if (seq := self.running(v)) and v.linked:
                seq.step(now)

    def capture(self, now: float) -> None:
        """pass_start "capture": start the pass once every UAV of the gate is captured."""
        if capture_start(self.vehicles, self.sequences, self.pass_, self.frame, now,
                         self.config):
            self._emit(-1, "info", f"formation established; flying the track at "
                                   f"{self.config.speed_mps:g} m/s")

    def left(self, v: WatchedVehicle) -> bool:
        """Whether `v` left our control (`control_states`): nothing more goes to it."""
        return self.control[v.uav].left

    def _watch_control(self) -> None:
        """Each linked vehicle's latest heartbeat through `control_states.step`."""
        for v in self.vehicles:
            if not v.linked or self.left(v):
                continue
            seq = self.sequences.get(v.uav)
            flown = self.pass_.start_pose(v.uav) is not None
            taken = (seq is not None and not seq.active and not seq.failed
                     if self.config.arm_and_takeoff else flown)
            excused = not flown or self.returning.engaged(v.uav) or any(
                order.engaged(v.uav) and (not order.settled(v.uav) or order.reached(v))
                for order in (self.holding.hold, self.holding.resume))
            heard = Heard(self.autopilot.mode_text(v.custom_mode, v.mode),
                          self.autopilot.flight.shown_by(v.custom_mode), v.armed, v.airborne,
                          taken, excused)
            self.control[v.uav], tells = control_step(self.control[v.uav], heard)
            for tell in tells:
                self._emit(v.uav, tell.level, f"sysid {v.sysid} {tell.text}")

    def order_due(self, v: WatchedVehicle, now: float) -> ModeOrder | None:
        if self.left(v):
            return None  # no order fights whoever took it
        if self.returning.engaged(v.uav):
            return self.returning if self.returning.due(v, now) else None
        return self.holding.order_due(v, now)

    def target_to_send(self, v: WatchedVehicle, now: float) -> tuple[Vec3, Vec3] | None:
        """The (position, velocity) setpoint for `v` now, or None: none goes out."""
        target = governed(self._catch_up, v.uav, self.pass_.target(v.uav, now), now)
        waits = self.autopilot.setpoints_in_flight_only and (
            self.running(v) is not None or not self.autopilot.flight.shown_by(v.custom_mode))
        if (target is None or waits or self.holding.stopped(v) or self.returning.engaged(v.uav)
                or self.left(v)):
            return None
        if v.position_ned is None or v.position_time is None:
            return target
        correction = self._cross_track.setdefault(
            v.uav, CrossTrack(self.autopilot.cross_track_gain))
        estimate = self.frame.from_ned(*v.position_ned)
        return (correction.setpoint(target[0], estimate, now - v.position_time, now), target[1])

    def status(self, v: WatchedVehicle, now: float) -> VehicleStatus:
        status = vehicle_status(v, now, self.pass_, self.frame, self.config.capture_radius_m,
                                self.sequences.get(v.uav), self._separation[v.uav])
        held = ("landed" if v.uav in self._landed else "returning"
                if self.returning.engaged(v.uav) else self.holding.phase(v))
        left = self.control[v.uav].phase()
        return replace(status, phase=left or held or status.phase, pass_plan=self._start_label,
                       pass_start_s=None if self.pass_.sent is None else self.pass_.sent.start_s,
                       behind=self.holding.behind.get(v.uav, ""), out_of_control=left)

    def _rejoin(self, now: float, why: str, here: bool = False, late: bool = False) -> None:
        """Held vehicles near their targets rejoin (`holds.Holding.rejoin`); `here`: the clock
        first moves to where the rearmost held one stands; `late`: `holds.Holding.fall_back`."""
        lag = lags(self.vehicles, self.pass_, self.frame, now)
        held = [lag[v.uav] for v in self.vehicles if self.holding.stopped(v)]
        if here and (text := resume_where_held(self.pass_, held)):
            self._emit(-1, "info", text)
            lag = lags(self.vehicles, self.pass_, self.frame, now)
        rejoin_m = self.config.speed_mps * REJOIN_S
        given = self.holding.rejoin(self.vehicles, lag, rejoin_m, why)
        if late:
            self.holding.fall_back(self.vehicles, lag, rejoin_m, why)
        for v in self.vehicles:  # behind a moving target: a gentle catch-up (`track.catch_up`)
            if (v.uav in given or late and not self.holding.stopped(v)) and (
                    lag[v.uav] or 0.0) > CATCH_UP_FROM_M:
                y = self.frame.from_ned(*v.position_ned)[1]
                self._catch_up[v.uav] = CatchUp(now, y, self.config.speed_mps)

    def _new_sequence(self, v: WatchedVehicle) -> ArmingSequence:
        def start_down() -> float:
            return self.frame.to_ned(*self.pass_.start_pose(v.uav))[2]

        return ArmingSequence(
            self.autopilot, v,
            send=lambda command, params, confirmation: self._send_command(
                v, command, params, confirmation),
            emit=lambda level, text: self._emit(v.uav, level, text), start_down=start_down,
            readiness_timeout_s=self.config.readiness_timeout_s)
