"""Who holds, and why: the planner's mission stop and the ground station's silence.

The bridge feeds it each new plan (`on_plan`, with the clean formation), everything heard
from the ground station (`gcs_heard`) and its clock (`check`); it asks which mode order is due
for a vehicle (`order_due`) and whether the setpoints are stopped (`stopped`). Not
thread-safe: the bridge holds its lock.

- Mission stop: a formation with every pose NaN after one with targets (`replan.hold_plan`)
  engages the hold order (`hold.HoldOrder`: LOITER / AUTO.LOITER) for every vehicle; a later
  plan releases it for the UAVs it gives a target, which stay in their hold mode until the
  pilot or a GCS switches them back (as before the ground-silence hold existed).
- Ground station silent (`gcs_timeout_s` > 0): the clock starts when the ground is first
  heard (never heard: waiting, no hold, like the planner's lost rule). Anything counts: a
  gcs/heartbeat, a plan message, a start message. Silent for longer than `gcs_timeout_s`: the
  setpoints to every vehicle stop and the hold order is engaged for every vehicle, with one
  event saying how long it was silent and what was last heard. Heard again: one event, and
  the vehicles keep holding. The hold ends only with a NEW plan identity (or a new start):
  the setpoints resume and a vehicle that gets a target and is still in the hold mode the
  bridge commanded is switched back to GUIDED / OFFBOARD (`hold.ResumeOrder`): the bridge
  put it there, so it may take it back. One in any other mode (a pilot switched it) is not
  taken back. One without a target (a UAV the planner declared lost meanwhile: the
  survivors' plan gives it NaN) keeps holding; a later plan that gives it a target takes it
  back the same way.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

from uav_insar_planner.mavlink.frames import Vec3
from uav_insar_planner.mavlink.hold import HoldOrder, ModeOrder, ResumeOrder
from uav_insar_planner.mavlink.supervision import WatchedVehicle
from uav_insar_planner.swarm import uav_name

Emit = Callable[[int, str, str], None]  # (uav or -1 for the swarm, level, text)


class GcsWatch:
    """The clock of the ground station's silence (`timeout_s` 0: off)."""

    def __init__(self, timeout_s: float):
        self.timeout_s = timeout_s
        self.last: float | None = None  # when the ground was last heard (None: never)
        self.what = ""  # what was last heard
        self.silent = False  # timed out and not heard since

    def heard(self, what: str, now: float) -> str | None:
        """Record `what` from the ground; the event text when this ends a silence."""
        back = None
        if self.silent and self.last is not None:
            back = f"ground station heard again ({what}) after {now - self.last:.1f} s silent"
        self.silent, self.last, self.what = False, now, what
        return back

    def check(self, now: float) -> str | None:
        """Why the ground is now silent for too long, once per silence; else None."""
        if self.timeout_s <= 0.0 or self.last is None or self.silent:
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
        word = "silent" if self.silent else "heard"
        return f"{word} {now - self.last:.1f} s{' ago' * (not self.silent)} ({self.what})"


class Holding:
    """See the module doc; `uavs` are the bridge's UAV indices, `emit` its event sink."""

    def __init__(self, autopilot: str, gcs_timeout_s: float, uavs: Sequence[int], emit: Emit):
        self.hold, self.resume = HoldOrder(autopilot), ResumeOrder(autopilot)
        self.gcs = GcsWatch(gcs_timeout_s)
        self._uavs, self._emit = tuple(uavs), emit
        self.gcs_hold = False  # setpoints stopped for the ground's silence
        self._gcs_held: set[int] = set()  # put in the hold mode for it, not yet given back

    def gcs_heard(self, what: str, now: float) -> None:
        back = self.gcs.heard(what, now)
        if back is not None:
            self._emit(-1, "info", back + ("; holding until a new plan or start"
                                           if self.gcs_hold else ""))

    def check(self, now: float) -> None:
        why = self.gcs.check(now)
        if why is None:
            return
        self.gcs_hold, self._gcs_held = True, set(self._uavs)
        self.resume.release()
        self.hold.engage(self._uavs)
        self._emit(-1, "warn", f"{why}: stopping the setpoints and commanding "
                               f"{self.hold.mode_name} to every vehicle")

    def on_plan(self, formation: Sequence[Vec3 | None], vehicles: Sequence[WatchedVehicle],
                flown_before: bool) -> None:
        """A new plan identity (or a new start for the plan flown) with this formation."""
        targets = {k for k, p in enumerate(formation) if p is not None}
        if not targets:
            if flown_before and not self.gcs_hold:
                self.hold.engage(self._uavs)
                self._emit(-1, "warn", "every pose NaN: the mission stopped; commanding "
                                       f"{self.hold.mode_name} to every vehicle")
            self.gcs_hold = False
            return
        self.gcs_hold = False
        self.hold.release(targets)
        for v in vehicles:
            if v.uav not in targets or v.uav not in self._gcs_held:
                continue
            self._gcs_held.discard(v.uav)
            if self.hold.reached(v):
                self.resume.engage([v.uav])
                self._emit(v.uav, "info", f"new plan after the ground-station hold: "
                                          f"{self.hold.mode_name} -> {self.resume.mode_name}")
            elif v.mode != self.resume.mode_name:
                self._emit(v.uav, "warn", f"in {v.mode}, not the {self.hold.mode_name} the "
                                          "bridge commanded (a pilot switched it): not taken "
                                          f"back to {self.resume.mode_name}")
        kept = sorted(self._gcs_held - targets)
        if kept:
            self._emit(-1, "info", "no target in the new plan for "
                                   f"{', '.join(uav_name(k) for k in kept)}: keeps holding")

    def stopped(self) -> bool:
        """No setpoints to any vehicle (the ground is or was silent, no new plan since)."""
        return self.gcs_hold

    def order_due(self, v: WatchedVehicle, now: float) -> ModeOrder | None:
        """The mode order to send `v` now (then call its `sent`), or None."""
        for order in (self.hold, self.resume):
            if order.due(v, now):
                return order
        return None

    def phase(self, v: WatchedVehicle) -> str:
        """The UAV's phase while the ground-silence hold holds it ("" otherwise)."""
        if self.gcs_hold:
            return (f"holding ({self.hold.mode_name}): ground station "
                    + ("heard again, waiting for a new plan or start" if not self.gcs.silent
                       else "silent"))
        if v.uav in self._gcs_held:
            return (f"holding ({self.hold.mode_name}) since the ground station fell silent: no "
                    "target in the current plan")
        return ""
