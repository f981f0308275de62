"""The planner's survey run (ros/survey_run.py) as named states and one pure step function:
`step(state, event, survey) -> (state, actions)`. No ROS here: every decision is testable
without a node.

  phase     what the swarm does                       left for
  IDLE      nothing flown yet                         TRANSIT: the first plan (Begin)
  TRANSIT   flies to the sortie's first strip's       STRIP: its pass start is published
            entries (take-off, transit, capture)        (Started: every UAV captured)
  STRIP     flies strip `current` on its clock        TURN: over (`SurveyLeg.over_at`) and
                                                        strips left in the sortie;
                                                      RETURN: over, and it was the sortie's last
  TURN      flies to the next strip's entries         STRIP: its pass start (Started)
  RETURN    returns to launch and lands (the bridges  TRANSIT: ~/next_sortie (NextSortie), the
            order it after a `last` strip), then        batteries changed
            waits for the operator
  DONE      every strip flown                         -

A strip interrupted while it is flown (Interrupted: a UAV lost, a re-plan, a hold) is never
counted as flown: it is flown again as the next attempt (a new pass with slots of its own),
at once when strips are left in the sortie, else first in the next sortie (the bridges return
after a `last` strip whatever happened on it, and the battery budget held the sortie as
planned, not a strip more); with no sortie left, in a sortie of its own.
"""
from __future__ import annotations

import enum
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

from uav_insar_planner.ros.start_states import Log
from uav_insar_planner.track.leg import over_at
from uav_insar_planner.track.pass_clock import PassClock


class Phase(enum.Enum):
    IDLE = "idle"
    TRANSIT = "transit"
    STRIP = "strip"
    TURN = "turn"
    RETURN = "return"
    DONE = "done"


@dataclass(frozen=True)
class SurveyFlight:
    """What the run needs of a survey: the sorties (strip indices in flight order) and each
    strip's imaged length [m]."""

    sorties: tuple[tuple[int, ...], ...]
    lengths_m: Mapping[int, float]


@dataclass(frozen=True)
class SurveyState:
    """The phase and what it holds (module docstring). `queue` is the sortie's strips still to
    fly, the current one first; `sorties_left` the sorties after this one."""

    phase: Phase = Phase.IDLE
    sortie: int = 0
    queue: tuple[int, ...] = ()
    sorties_left: tuple[tuple[int, ...], ...] = ()
    attempts: Mapping[int, int] = field(default_factory=dict)  # strip -> attempts begun
    clock: PassClock | None = None  # the running strip's start (wall clock)
    interrupted: str = ""  # why the running strip was interrupted ("": it was not)
    flown: tuple[int, ...] = ()  # strips flown whole, in order

    @property
    def current(self) -> int | None:
        return self.queue[0] if self.queue else None

    @property
    def last(self) -> bool:
        """Whether the current strip is the sortie's last."""
        return len(self.queue) == 1


@dataclass(frozen=True)
class Begin:
    """The first plan is ready: fly the survey."""


@dataclass(frozen=True)
class Started:
    """The current strip's pass start was published (wall clock)."""

    clock: PassClock


@dataclass(frozen=True)
class Tick:
    now_s: float  # wall clock


@dataclass(frozen=True)
class Interrupted:
    why: str


@dataclass(frozen=True)
class NextSortie:
    """The operator says the next sortie may go (~/next_sortie)."""


@dataclass(frozen=True)
class Fly:
    """Publish the plan on strip `strip` of sortie `sortie`, attempt `attempt`."""

    strip: int
    sortie: int
    attempt: int
    last: bool


@dataclass(frozen=True)
class Reply:
    """The answer to NextSortie: accepted or not, and why."""

    ok: bool
    text: str


Event = Begin | Started | Tick | Interrupted | NextSortie
Action = Fly | Log | Reply


def step(state: SurveyState, event: Event, survey: SurveyFlight
         ) -> tuple[SurveyState, tuple[Action, ...]]:
    """The next state and what to do (module docstring)."""
    if isinstance(event, Begin):
        if state.phase is not Phase.IDLE or not survey.sorties:
            return state, ()
        first = replace(state, sorties_left=survey.sorties[1:])
        return _fly_sortie(first, 0, survey.sorties[0], survey)
    if isinstance(event, NextSortie):
        return _next_sortie(state, survey)
    if isinstance(event, Started):
        if state.phase in (Phase.TRANSIT, Phase.TURN):
            return replace(state, phase=Phase.STRIP, clock=event.clock, interrupted=""), ()
        return state, ()
    if isinstance(event, Interrupted):
        if state.phase is Phase.STRIP and not state.interrupted:
            return replace(state, interrupted=event.why), (Log("warning", (
                f"survey: strip {state.current} interrupted ({event.why}): it will be flown "
                "again, not counted as flown")),)
        return state, ()
    if (state.phase is Phase.STRIP and state.clock is not None
            and event.now_s >= over_at(state.clock, survey.lengths_m[state.current])):
        return _strip_over(state, survey)
    return state, ()


def _fly(state: SurveyState, phase: Phase, queue: Sequence[int]) -> tuple[SurveyState, Fly]:
    strip = queue[0]
    attempts = {**state.attempts, strip: state.attempts.get(strip, 0) + 1}
    new = replace(state, phase=phase, queue=tuple(queue), attempts=attempts, clock=None,
                  interrupted="")
    return new, Fly(strip, new.sortie, attempts[strip], new.last)


def _fly_sortie(state: SurveyState, sortie: int, queue: Sequence[int], survey: SurveyFlight
                ) -> tuple[SurveyState, tuple[Action, ...]]:
    new, fly = _fly(replace(state, sortie=sortie), Phase.TRANSIT, queue)
    return new, (fly, Log("info", (
        f"survey: sortie {sortie + 1}: strips {', '.join(map(str, queue))}; flying to strip "
        f"{queue[0]}'s entries")))


def _strip_over(state: SurveyState, survey: SurveyFlight
                ) -> tuple[SurveyState, tuple[Action, ...]]:
    strip, rest = state.current, state.queue[1:]
    said: tuple[Action, ...] = ()
    flown = state.flown
    left = state.sorties_left
    if state.interrupted:
        if rest:
            rest = (strip,) + rest
        else:  # the bridges return after a last strip: it goes first in the next sortie
            left = ((strip,) + left[0],) + left[1:] if left else ((strip,),)
            said = (Log("warning", f"survey: strip {strip} goes first in the next sortie"),)
    else:
        flown = flown + (strip,)
        said = (Log("info", f"survey: strip {strip} flown ({len(flown)} of "
                            f"{len(survey.lengths_m)})"),)
    state = replace(state, flown=flown, sorties_left=left)
    if rest:
        new, fly = _fly(state, Phase.TURN, rest)
        return new, said + (fly, Log("info", f"survey: turning to strip {rest[0]}"))
    done = not left
    new = replace(state, phase=Phase.DONE if done else Phase.RETURN, queue=(), clock=None,
                  interrupted="")
    text = (f"survey complete: {len(flown)} strips flown; the UAVs return and land" if done
            else f"survey: sortie {state.sortie + 1} over: the UAVs return and land; call "
                 "~/next_sortie when the batteries are changed")
    return new, said + (Log("info", text),)


def _next_sortie(state: SurveyState, survey: SurveyFlight
                 ) -> tuple[SurveyState, tuple[Action, ...]]:
    if state.phase is not Phase.RETURN:
        why = {Phase.IDLE: "the survey has not begun (no plan yet)",
               Phase.DONE: "every sortie is flown"}.get(
            state.phase, f"sortie {state.sortie + 1} is being flown ({state.phase.value}, "
                         f"strip {state.current})")
        return state, (Reply(False, f"refused: {why}"),)
    queue, left = state.sorties_left[0], state.sorties_left[1:]
    new, actions = _fly_sortie(replace(state, sorties_left=left), state.sortie + 1, queue,
                               survey)
    return new, actions + (Reply(True, f"sortie {state.sortie + 2}: flying strips "
                                       f"{', '.join(map(str, queue))}"),)
