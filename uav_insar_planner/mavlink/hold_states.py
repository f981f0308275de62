"""Each UAV's hold state and its transitions, as plain values: `step(holds, event)` returns the
next state and the actions to take. No I/O, no clock: `holds.Holding` turns the ground
station's clock (`holds.GcsWatch`) and the bridge's calls into these events and applies the
actions to its mode orders and event sink.

A held UAV gets no setpoints and has the hold order engaged (LOITER / AUTO.LOITER). Held
states (`Hold`), all but FLYING:

    state           entered by                                   phase on /diagnostics
    FLYING          start; a rejoin                              (its own, not ours)
    HELD_SILENT     Silence: every UAV, whatever it was          ground station silent
    HELD_WAITING    Heard again after a Silence                  waiting for the pass
    HELD_BEHIND     a Rejoin finding it too far behind, or       its `behind` text
                    without a target; a late start (FallBack);
                    a Plan giving a HELD_NO_TARGET one a target
                    when a Rejoin had found it so
    HELD_NO_TARGET  a Plan giving no target to a UAV held for    no target in the plan
                    a silence (or rejoined since, no plan yet)

- Rejoin (the ground heard again, a new start or plan): nothing while the ground is silent;
  else each held UAV at most `rejoin_m` behind its target goes back to FLYING (hold
  released; the resume order engaged only if it is still in a mode the bridge set: one a
  pilot switched elsewhere is not taken back). One farther behind, or without target or
  position, keeps holding, its `behind` text told once per change.
- FallBack (a pass start heard late): a flying UAV more than `rejoin_m` behind holds rather
  than sprint.
- Plan: every pose NaN after a plan flown is the mission stop, an order and no state: the
  hold for every UAV unless one is already held (the planner's stop is the plan itself: no
  targets, so no setpoints). Else the hold is released for the flying UAVs given a target
  (they stay in the hold mode until a pilot or GCS switches them back), and a UAV held for a
  silence, or rejoined after one, that no plan has given a target since and this one gives
  none is (again) held: the survivors' plan has left it out, so it must not fly into them.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from enum import Enum

from uav_insar_planner.swarm import uav_name


class Hold(Enum):
    """One UAV's hold state (the module doc's table)."""

    FLYING = "flying"
    HELD_SILENT = "held: ground station silent"
    HELD_WAITING = "held: heard again, waiting for the pass to resume"
    HELD_BEHIND = "held: too far behind its target, or without one"
    HELD_NO_TARGET = "held: no target in the plan flown"

    @property
    def held(self) -> bool:
        return self is not Hold.FLYING


@dataclass(frozen=True)
class UavHold:
    """A UAV's state, why it cannot rejoin ("" until a rejoin or late start found so), and
    whether it was held for a silence (or rejoined after one) with no plan giving it a target
    since: a plan without its target then holds it."""

    state: Hold = Hold.FLYING
    behind: str = ""
    since_silence: bool = False


@dataclass(frozen=True)
class Holds:
    """The swarm's hold state: each UAV's, whether the ground is silent (no rejoin then), and
    the names of the hold and flight modes the texts tell."""

    uavs: Mapping[int, UavHold]
    hold_mode: str
    resume_mode: str
    silent: bool = False

    @classmethod
    def start(cls, uavs: Iterable[int], hold_mode: str, resume_mode: str) -> Holds:
        return cls({k: UavHold() for k in uavs}, hold_mode, resume_mode)

    def held(self) -> list[int]:
        return [k for k, u in self.uavs.items() if u.state.held]

    def phase(self, uav: int) -> str:
        """The UAV's phase while held ("" when flying)."""
        u, mode = self.uavs[uav], self.hold_mode
        if u.state is Hold.HELD_NO_TARGET:
            return (f"holding ({mode}) since the ground station fell silent: no target in the "
                    "current plan")
        if u.state is Hold.HELD_SILENT:
            return f"holding ({mode}): ground station silent"
        if u.state is Hold.HELD_BEHIND:
            return f"holding ({mode}): {u.behind}"
        if u.state is Hold.HELD_WAITING:
            return (f"holding ({mode}): ground station heard again, waiting for the pass to "
                    "resume")
        return ""


# --- events (inputs) ---------------------------------------------------------------------


@dataclass(frozen=True)
class Silence:
    """The ground station fell silent (`why`: `GcsWatch.check`'s text)."""

    why: str


@dataclass(frozen=True)
class HeardAgain:
    """The ground station was heard after a silence (`text`: `GcsWatch.heard`'s)."""

    text: str


@dataclass(frozen=True)
class Plan:
    """A new plan: the UAVs it gives a target; whether a plan with targets was flown before."""

    targets: frozenset[int]
    flown_before: bool


@dataclass(frozen=True)
class Seen:
    """A vehicle as a rejoin sees it: how far its target is ahead of it along track (metres;
    None: no target or no position), its mode as last heard and whether that is the hold or
    the flight mode (a mode the bridge set)."""

    uav: int
    lag: float | None
    mode: str = ""
    ours: bool = True


@dataclass(frozen=True)
class Rejoin:
    """Give back the held UAVs near their targets (`why`: the occasion, for the texts)."""

    seen: Sequence[Seen]
    rejoin_m: float
    why: str


@dataclass(frozen=True)
class FallBack:
    """A pass start heard late: flying UAVs more than `rejoin_m` behind hold."""

    seen: Sequence[Seen]
    rejoin_m: float
    why: str


Event = Silence | HeardAgain | Plan | Rejoin | FallBack


# --- actions (outputs) -------------------------------------------------------------------


@dataclass(frozen=True)
class OrderHold:
    """Engage the hold order for `uavs` (and end any resume order: one order per vehicle)."""

    uavs: tuple[int, ...]


@dataclass(frozen=True)
class ReleaseHold:
    """End the hold order for `uavs`; their mode stays what it is."""

    uavs: tuple[int, ...]


@dataclass(frozen=True)
class OrderResume:
    """Engage the order back into the flight mode for `uav`."""

    uav: int


@dataclass(frozen=True)
class Tell:
    """An event for the log (`uav` -1: the swarm)."""

    uav: int
    level: str
    text: str


Action = OrderHold | ReleaseHold | OrderResume | Tell


# --- transitions -------------------------------------------------------------------------


def step(holds: Holds, event: Event) -> tuple[Holds, list[Action]]:
    """The state after `event` and the actions it asks for (the module doc)."""
    if isinstance(event, Silence):
        return _silence(holds, event)
    if isinstance(event, HeardAgain):
        uavs = {k: replace(u, state=Hold.HELD_WAITING) if u.state is Hold.HELD_SILENT else u
                for k, u in holds.uavs.items()}
        return replace(holds, uavs=uavs, silent=False), [Tell(-1, "info", event.text)]
    if isinstance(event, Plan):
        return _plan(holds, event)
    if isinstance(event, Rejoin):
        return _rejoin(holds, event)
    return _fall_back(holds, event)


def _silence(holds: Holds, event: Silence) -> tuple[Holds, list[Action]]:
    uavs = {k: UavHold(Hold.HELD_SILENT, since_silence=True) for k in holds.uavs}
    return replace(holds, uavs=uavs, silent=True), [
        OrderHold(tuple(uavs)),
        Tell(-1, "warn", f"{event.why}: stopping the setpoints and commanding "
                         f"{holds.hold_mode} to every vehicle")]


def _plan(holds: Holds, event: Plan) -> tuple[Holds, list[Action]]:
    if not event.targets:
        if event.flown_before and not holds.held():
            return holds, [OrderHold(tuple(holds.uavs)),
                           Tell(-1, "warn", "every pose NaN: the mission stopped; commanding "
                                            f"{holds.hold_mode} to every vehicle")]
        return holds, []
    actions: list[Action] = []
    flying = tuple(k for k in sorted(event.targets)
                   if k in holds.uavs and not holds.uavs[k].state.held)
    if flying:
        actions.append(ReleaseHold(flying))
    uavs = dict(holds.uavs)
    for k in event.targets & uavs.keys():
        u = uavs[k]
        state = u.state
        if state is Hold.HELD_NO_TARGET:  # a target again: held as it would be without
            state = (Hold.HELD_BEHIND if u.behind else
                     Hold.HELD_SILENT if holds.silent else Hold.HELD_WAITING)
        uavs[k] = replace(u, state=state, since_silence=False)
    kept = sorted(k for k, u in uavs.items()
                  if u.since_silence and u.state is not Hold.HELD_NO_TARGET)
    if kept:  # (lost meanwhile: the survivors' plan gives it NaN; never into their way)
        for k in kept:
            uavs[k] = replace(uavs[k], state=Hold.HELD_NO_TARGET)
        actions += [OrderHold(tuple(kept)),
                    Tell(-1, "info", "no target in the new plan for "
                                     f"{', '.join(uav_name(k) for k in kept)}: keeps holding")]
    return replace(holds, uavs=uavs), actions


def _too_far(lag: float, rejoin_m: float) -> str:
    return (f"{lag:.2f} m behind its target, more than the {rejoin_m:.2f} m it may catch up: "
            "cannot keep the pass, keeps holding")


def _rejoin(holds: Holds, event: Rejoin) -> tuple[Holds, list[Action]]:
    if holds.silent:
        return holds, []  # still silent: nothing is given back
    uavs, actions = dict(holds.uavs), []
    for s in event.seen:
        u = uavs.get(s.uav, UavHold())
        if not u.state.held:
            continue
        if s.lag is not None and s.lag <= event.rejoin_m:
            uavs[s.uav] = replace(u, state=Hold.FLYING, behind="")
            actions += _give_back(holds, s, f"{event.why}: rejoins the pass, "
                                            f"{max(s.lag, 0.0):.2f} m behind its target "
                                            f"(rejoin limit {event.rejoin_m:.2f} m)")
            continue
        text = ("no target in the plan flown: keeps holding" if s.lag is None else
                _too_far(s.lag, event.rejoin_m))
        if u.behind != text:
            state = u.state if u.state is Hold.HELD_NO_TARGET else Hold.HELD_BEHIND
            uavs[s.uav] = replace(u, state=state, behind=text)
            actions.append(Tell(s.uav, "warn", f"{event.why}: {text}"))
    return replace(holds, uavs=uavs), actions


def _give_back(holds: Holds, s: Seen, text: str) -> list[Action]:
    if s.ours:  # (still in the flying mode as last heard: the hold order may be on its way)
        return [ReleaseHold((s.uav,)), OrderResume(s.uav),
                Tell(s.uav, "info", f"{text}; {holds.hold_mode} -> {holds.resume_mode}")]
    return [ReleaseHold((s.uav,)),
            Tell(s.uav, "info", f"{text}; in {s.mode}, not the {holds.hold_mode} the bridge "
                                f"commanded (a pilot switched it): not taken back to "
                                f"{holds.resume_mode}")]


def _fall_back(holds: Holds, event: FallBack) -> tuple[Holds, list[Action]]:
    uavs, actions = dict(holds.uavs), []
    for s in event.seen:
        u = uavs.get(s.uav, UavHold())
        if u.state.held or s.lag is None or s.lag <= event.rejoin_m:
            continue
        text = _too_far(s.lag, event.rejoin_m)
        uavs[s.uav] = replace(u, state=Hold.HELD_BEHIND, behind=text)
        actions += [OrderHold((s.uav,)),
                    Tell(s.uav, "warn", f"{event.why}: {text} ({holds.hold_mode}, no sprint)")]
    return replace(holds, uavs=uavs), actions
