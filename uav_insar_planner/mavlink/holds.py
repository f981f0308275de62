"""Who holds, and why: the planner's mission stop and the ground station's silence, and how a
held UAV gets back into the pass. The states and their transitions are `hold_states` (plain
values, `hold_states.step`); `Holding` feeds them the bridge's calls and applies the actions
to its two mode orders and its event sink.

The bridge feeds it each new plan (`on_plan`, with the clean formation), everything heard
from the ground station (`gcs_heard`) and its clock (`check`); it asks which mode order is due
for a vehicle (`order_due`) and whether it is held (`stopped`: its setpoints stop). Not
thread-safe: the bridge holds its lock.

- Mission stop: a formation with every pose NaN after one with targets (`replanning.plans`)
  engages the hold order (`mode_orders.hold_order`: LOITER / AUTO.LOITER) for every vehicle; a
  later plan releases it for the UAVs it gives a target, which stay in their hold mode until the
  pilot or a GCS switches them back.
- Ground station silent (`gcs_timeout_s` > 0, `GcsWatch`): the clock starts with the first
  gcs/heartbeat (before one was matched, silence is not loss: a lossy radio may take seconds to
  match the best-effort heartbeat, while the reliable plan is already there). From then on
  anything counts: a heartbeat, a plan message, a start message. Silent for longer than
  `gcs_timeout_s`: every vehicle is held (no setpoints, the hold order), with one event saying
  how long it was silent and what was last heard.
- Getting back (`rejoin`, called by the bridge when the ground is heard again and when a new
  start or plan comes): a held vehicle whose target, on the pass clock it flies, is at most
  `rejoin_m` ahead of where it stands rejoins the pass: its setpoints resume, and if it is
  still in the hold mode the bridge commanded it is switched back to GUIDED / OFFBOARD
  (`mode_orders.resume_order`: the bridge put it there, so it may take it back; one a pilot
  switched to another mode is not taken back). One farther behind cannot keep the pass without
  a sprint: it keeps holding and is reported `behind` (for the planner to resume the swarm
  from where it stands, or replan without it). A vehicle without a target (the planner's
  survivors' plan gives it NaN) keeps holding. Heard again through a plan other than the one
  flown, or a heartbeat naming one, the bridge waits for that plan before any rejoin
  (`flight_state.FlightState.gcs_heard`): the planner may have re-planned without a held UAV
  during the silence.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

from uav_insar_planner.autopilots.profiles import AutopilotProfile
from uav_insar_planner.mavlink.hold_states import (
    Event,
    FallBack,
    HeardAgain,
    Hold,
    Holds,
    OrderHold,
    OrderResume,
    Plan,
    Rejoin,
    ReleaseHold,
    Seen,
    Silence,
    Tell,
    step,
)
from uav_insar_planner.mavlink.mode_orders import ModeOrder, hold_order, resume_order
from uav_insar_planner.mavlink.report import Emit
from uav_insar_planner.mavlink.supervision import WatchedVehicle
from uav_insar_planner.plan import Vec3

# A held UAV rejoins when its target is at most this much of the pass (speed_mps * REJOIN_S)
# ahead of it: a short hold, caught up in a few seconds; farther behind it would sprint.
REJOIN_S = 1.0


class GcsWatch:
    """The clock of the ground station's silence (`timeout_s` 0: off)."""

    def __init__(self, timeout_s: float):
        self.timeout_s = timeout_s
        self.last: float | None = None  # when the ground was last heard (None: never)
        self.what = ""  # what was last heard
        self.silent = False  # timed out and not heard since
        self.armed = False  # a heartbeat was heard: silence counts from now on

    def heard(self, what: str, now: float, heartbeat: bool = False) -> str | None:
        """Record `what` from the ground (`heartbeat`: a gcs/heartbeat); the event text when
        this ends a silence."""
        back = None
        if self.silent and self.last is not None:
            back = f"ground station heard again ({what}) after {now - self.last:.1f} s silent"
        self.silent, self.last, self.what = False, now, what
        self.armed = self.armed or heartbeat
        return back

    def check(self, now: float) -> str | None:
        """Why the ground is now silent for too long, once per silence; else None."""
        if self.timeout_s <= 0.0 or not self.armed or self.last is None or self.silent:
            return None
        if now - self.last <= self.timeout_s:
            return None
        self.silent = True
        return (f"ground station silent for {now - self.last:.1f} s (gcs_timeout_s "
                f"{self.timeout_s:g}; last heard: {self.what})")

    def state(self, now: float) -> str:
        """off / waiting (never heard) / heard 0.3 s ago (...) / silent 2.1 s (...)."""
        if self.timeout_s <= 0.0:
            return "off"
        if self.last is None:
            return "waiting (never heard)"
        if not self.armed:
            return f"waiting (no gcs/heartbeat yet; heard {now - self.last:.1f} s ago: " \
                   f"{self.what})"
        word = "silent" if self.silent else "heard"
        return f"{word} {now - self.last:.1f} s{' ago' * (not self.silent)} ({self.what})"


class Holding:
    """See the module doc; `uavs` are the bridge's UAV indices, `emit` its event sink."""

    def __init__(self, autopilot: AutopilotProfile, gcs_timeout_s: float, uavs: Sequence[int],
                 emit: Emit):
        self.hold, self.resume = hold_order(autopilot), resume_order(autopilot)
        self.gcs = GcsWatch(gcs_timeout_s)
        self.holds = Holds.start(uavs, self.hold.mode.name, self.resume.mode.name)
        self._emit = emit

    def _apply(self, event: Event) -> None:
        """Step the state by `event` and carry out its actions."""
        self.holds, actions = step(self.holds, event)
        for action in actions:
            if isinstance(action, OrderHold):
                # One order per vehicle: a resume still engaged (a rejoin just before the plan
                # that took the UAV out) would alternate with the hold and leave it flying.
                self.resume.release(action.uavs)
                self.hold.engage(action.uavs)
            elif isinstance(action, ReleaseHold):
                self.hold.release(action.uavs)
            elif isinstance(action, OrderResume):
                self.resume.engage([action.uav])
            elif isinstance(action, Tell):
                self._emit(action.uav, action.level, action.text)

    @property
    def behind(self) -> dict[int, str]:
        """Held, too far behind (or without a target) to rejoin: why, per UAV."""
        return {k: u.behind for k, u in self.holds.uavs.items() if u.behind}

    def state(self, uav: int) -> Hold:
        return self.holds.uavs[uav].state

    def gcs_heard(self, what: str, now: float, heartbeat: bool = False) -> bool:
        """True when this ends a silence while vehicles are held (the bridge then calls
        `rejoin`)."""
        back = self.gcs.heard(what, now, heartbeat)
        if back is None:
            return False
        self._apply(HeardAgain(back))
        return bool(self.holds.held())

    def check(self, now: float) -> None:
        """The clock moved on: every vehicle held once the ground is silent too long."""
        why = self.gcs.check(now)
        if why is not None:
            self._apply(Silence(why))

    def _seen(self, vehicles: Sequence[WatchedVehicle],
              lags: Mapping[int, float | None]) -> tuple[Seen, ...]:
        return tuple(Seen(v.uav, lags.get(v.uav), v.mode,
                          self.hold.reached(v) or self.resume.reached(v)) for v in vehicles)

    def rejoin(self, vehicles: Sequence[WatchedVehicle], lags: Mapping[int, float | None],
               rejoin_m: float, why: str) -> list[int]:
        """Give back every held vehicle whose target is at most `rejoin_m` ahead of it
        (`lags`, metres along track; None: no target or no position), see the module doc;
        `why` names the occasion for the log; the UAVs given back."""
        before = set(self.holds.held())
        self._apply(Rejoin(self._seen(vehicles, lags), rejoin_m, why))
        return [v.uav for v in vehicles if v.uav in before and not self.state(v.uav).held]

    def fall_back(self, vehicles: Sequence[WatchedVehicle], lags: Mapping[int, float | None],
                  rejoin_m: float, why: str) -> None:
        """A pass start heard late (after a lossy radio's repair): each flying vehicle more
        than `rejoin_m` behind its target holds rather than sprint, reported `behind`."""
        self._apply(FallBack(self._seen(vehicles, lags), rejoin_m, why))

    def on_plan(self, formation: Sequence[Vec3 | None], flown_before: bool) -> None:
        """A new plan identity with this formation: the mission stop (every pose NaN), or the
        end of it for the UAVs given a target. A ground-silence hold is not ended here: the
        bridge calls `rejoin` with the new plan's targets."""
        targets = frozenset(k for k, p in enumerate(formation) if p is not None)
        self._apply(Plan(targets, flown_before))

    def stopped(self, v: WatchedVehicle) -> bool:
        """Whether `v` is held: no setpoints go to it."""
        return self.state(v.uav).held

    def order_due(self, v: WatchedVehicle, now: float) -> ModeOrder | None:
        """The mode order to send `v` now (then call its `sent`), or None."""
        for order in (self.hold, self.resume):
            if order.due(v, now):
                return order
        return None

    def phase(self, v: WatchedVehicle) -> str:
        """The UAV's phase while held ("" otherwise)."""
        return self.holds.phase(v.uav)
