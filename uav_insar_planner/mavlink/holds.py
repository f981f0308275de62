"""Who holds, and why: the planner's mission stop and the ground station's silence, and how a
held UAV gets back into the pass.

The bridge feeds it each new plan (`on_plan`, with the clean formation), everything heard
from the ground station (`gcs_heard`) and its clock (`check`); it asks which mode order is due
for a vehicle (`order_due`) and whether its setpoints are stopped (`stopped`). Not
thread-safe: the bridge holds its lock.

- Mission stop: a formation with every pose NaN after one with targets (`replanning.plans`)
  engages the hold order (`mode_orders.hold_order`: LOITER / AUTO.LOITER) for every vehicle; a
  later plan releases it for the UAVs it gives a target, which stay in their hold mode until the
  pilot or a GCS switches them back.
- Ground station silent (`gcs_timeout_s` > 0): the clock starts with the first gcs/heartbeat
  (before one was matched, silence is not loss: a lossy radio may take seconds to match the
  best-effort heartbeat, while the reliable plan is already there). From then on anything
  counts: a heartbeat, a plan message, a start message. Silent for longer than
  `gcs_timeout_s`: the setpoints to every vehicle stop and the hold order is engaged for
  every vehicle, with one event saying how long it was silent and what was last heard.
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

from collections.abc import Callable, Mapping, Sequence

from uav_insar_planner.autopilots.profiles import AutopilotProfile
from uav_insar_planner.mavlink.mode_orders import ModeOrder, hold_order, resume_order
from uav_insar_planner.mavlink.supervision import WatchedVehicle
from uav_insar_planner.plan import Vec3
from uav_insar_planner.swarm import uav_name

Emit = Callable[[int, str, str], None]  # (uav or -1 for the swarm, level, text)
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
        self._uavs, self._emit = tuple(uavs), emit
        self._stopped: set[int] = set()  # setpoints stopped for the ground's silence
        self.behind: dict[int, str] = {}  # held, too far behind to rejoin: why
        self._gcs_held: set[int] = set()  # held for a silence, no plan has given a target since
        self._no_target: set[int] = set()  # of those, held again: a plan gave it no target

    @property
    def held(self) -> bool:
        """Whether any vehicle is held for the ground's silence."""
        return bool(self._stopped)

    def gcs_heard(self, what: str, now: float, heartbeat: bool = False) -> bool:
        """True when this ends a silence while vehicles are held (the bridge then calls
        `rejoin`)."""
        back = self.gcs.heard(what, now, heartbeat)
        if back is not None:
            self._emit(-1, "info", back)
        return back is not None and self.held

    def check(self, now: float) -> None:
        why = self.gcs.check(now)
        if why is None:
            return
        self._stopped = set(self._uavs)
        self._gcs_held, self._no_target = set(self._uavs), set()
        self.behind = {}
        self._order_hold(self._uavs)
        self._emit(-1, "warn", f"{why}: stopping the setpoints and commanding "
                               f"{self.hold.mode.name} to every vehicle")

    def rejoin(self, vehicles: Sequence[WatchedVehicle], lags: Mapping[int, float | None],
               rejoin_m: float, why: str) -> list[int]:
        """Give back every held vehicle whose target is at most `rejoin_m` ahead of it
        (`lags`, metres along track; None: no target or no position), see the module doc;
        `why` names the occasion for the log; the UAVs given back."""
        given: list[int] = []
        if self.gcs.silent:
            return given  # still silent: nothing is given back
        for v in vehicles:
            if v.uav not in self._stopped:
                continue
            lag = lags.get(v.uav)
            if lag is not None and lag <= rejoin_m:
                self._give_back(v, f"{why}: rejoins the pass, {max(lag, 0.0):.2f} m behind its "
                                   f"target (rejoin limit {rejoin_m:.2f} m)")
                given.append(v.uav)
                continue
            text = ("no target in the plan flown: keeps holding" if lag is None else
                    f"{lag:.2f} m behind its target, more than the {rejoin_m:.2f} m it may "
                    "catch up: cannot keep the pass, keeps holding")
            if self.behind.get(v.uav) != text:
                self.behind[v.uav] = text
                self._emit(v.uav, "warn", f"{why}: {text}")
        return given

    def fall_back(self, vehicles: Sequence[WatchedVehicle], lags: Mapping[int, float | None],
                  rejoin_m: float, why: str) -> None:
        """A pass start heard late (after a lossy radio's repair): each flying vehicle more
        than `rejoin_m` behind its target holds rather than sprint, reported `behind`."""
        for v in vehicles:
            lag = lags.get(v.uav)
            if v.uav in self._stopped or lag is None or lag <= rejoin_m:
                continue
            self._stopped.add(v.uav)
            self._order_hold([v.uav])
            self.behind[v.uav] = (f"{lag:.2f} m behind its target, more than the "
                                  f"{rejoin_m:.2f} m it may catch up: cannot keep the pass, "
                                  "keeps holding")
            self._emit(v.uav, "warn", f"{why}: {self.behind[v.uav]} ({self.hold.mode.name}, "
                                      "no sprint)")

    def _give_back(self, v: WatchedVehicle, text: str) -> None:
        self._stopped.discard(v.uav)
        self.behind.pop(v.uav, None)
        self.hold.release([v.uav])
        if self.hold.reached(v) or self.resume.reached(v):
            # (still in the flying mode as last heard: the hold order may be on its way)
            self.resume.engage([v.uav])
            text += f"; {self.hold.mode.name} -> {self.resume.mode.name}"
        else:
            text += (f"; in {v.mode}, not the {self.hold.mode.name} the bridge commanded (a "
                     f"pilot switched it): not taken back to {self.resume.mode.name}")
        self._emit(v.uav, "info", text)

    def on_plan(self, formation: Sequence[Vec3 | None], flown_before: bool) -> None:
        """A new plan identity with this formation: the mission stop (every pose NaN), or the
        end of it for the UAVs given a target. A ground-silence hold is not ended here: the
        bridge calls `rejoin` with the new plan's targets."""
        targets = {k for k, p in enumerate(formation) if p is not None}
        if not targets:
            if flown_before and not self.held:
                self._order_hold(self._uavs)
                self._emit(-1, "warn", "every pose NaN: the mission stopped; commanding "
                                       f"{self.hold.mode.name} to every vehicle")
            return
        self.hold.release(targets - self._stopped)
        self._gcs_held -= targets
        self._no_target -= targets
        kept = sorted(self._gcs_held - self._no_target)
        if kept:  # (lost meanwhile: the survivors' plan gives it NaN; never into their way)
            self._no_target.update(kept)
            self._stopped.update(kept)
            self._order_hold(kept)
            self._emit(-1, "info", "no target in the new plan for "
                                   f"{', '.join(uav_name(k) for k in kept)}: keeps holding")

    def _order_hold(self, uavs: Sequence[int]) -> None:
        # One order per vehicle: a resume still engaged (a rejoin just before the plan that
        # took the UAV out) would alternate with the hold and leave it flying.
        self.resume.release(uavs)
        self.hold.engage(uavs)

    def stopped(self, v: WatchedVehicle) -> bool:
        """No setpoints to `v` (held for the ground's silence, not given back)."""
        return v.uav in self._stopped

    def order_due(self, v: WatchedVehicle, now: float) -> ModeOrder | None:
        """The mode order to send `v` now (then call its `sent`), or None."""
        for order in (self.hold, self.resume):
            if order.due(v, now):
                return order
        return None

    def phase(self, v: WatchedVehicle) -> str:
        """The UAV's phase while the ground-silence hold holds it ("" otherwise)."""
        if v.uav not in self._stopped:
            return ""
        if v.uav in self._no_target:
            return (f"holding ({self.hold.mode.name}) since the ground station fell silent: no "
                    "target in the current plan")
        if self.gcs.silent:
            return f"holding ({self.hold.mode.name}): ground station silent"
        if v.uav in self.behind:
            return f"holding ({self.hold.mode.name}): {self.behind[v.uav]}"
        return (f"holding ({self.hold.mode.name}): ground station heard again, waiting for "
                "the pass to resume")

