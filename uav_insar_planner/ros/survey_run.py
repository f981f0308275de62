"""The planner flies a survey (`survey_file`: the survey.json `uav-insar survey` wrote), strip
after strip; the decisions are ros/survey_states.py's pure step function, this is its node.

Each strip is the planner's current plan published on the strip (plan_msgs: the formation's
frame_id names it): the formation in the strip's frame (`Strip.frame` with the plan's master
x0, so the master flies the strip's line), the power schedule of that strip's slots and
station (survey/planning.py `strip_plan`). The pass start is the planner's usual one
(ros/formation_start.py: every flown UAV captured at its entry, then one start), so a turn
is a transit to the next strip's entries and a capture. A strip is over `track.leg.SETTLE_S`
after its imaged part; the sortie's last strip is marked `last`, after which every bridge
orders its vehicle home (RTL) on its own. `~/next_sortie` (std_srvs/Trigger) lets the next
sortie go once the batteries are changed (the planner's service calls `next_sortie`);
refused, with why, at any other time.

A strip flown while a UAV is declared lost, or while the plan changes its formation (a re-plan,
the hold plan), is interrupted and flown again (survey_states). Diagnostics: `planner: survey`
(phase, sortie, strip, attempts, strips flown).
"""
from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import replace

from rclpy.node import Node

from uav_insar_planner import published
from uav_insar_planner.params import Params
from uav_insar_planner.plan import Plan
from uav_insar_planner.ros.survey_states import (
    Begin,
    Fly,
    Interrupted,
    Log,
    NextSortie,
    Phase,
    Reply,
    Started,
    SurveyFlight,
    SurveyState,
    Tick,
    step,
)
from uav_insar_planner.survey.planning import strip_plan
from uav_insar_planner.survey.survey_file import SurveyFile, read_survey
from uav_insar_planner.swarm import uav_name
from uav_insar_planner.track.leg import SurveyLeg
from uav_insar_planner.track.pass_clock import PassClock

TICK_PERIOD_S = 0.2
SURVEY_MAX_BYTES = 50 << 20


def survey_for(path: str, params: Params) -> SurveyFile:
    """The survey file at `path`, flown under `params`; ValueError (one line, naming
    survey_file) when it cannot be read or was planned at another speed."""
    try:
        with open(path, "rb") as f:
            data = f.read(SURVEY_MAX_BYTES + 1)
        if len(data) > SURVEY_MAX_BYTES:
            raise ValueError(f"larger than {SURVEY_MAX_BYTES >> 20} MiB")
        survey = read_survey(data.decode("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ValueError(f"survey_file: {path[:80]!r}: {' '.join(str(exc).split())}; expected "
                         "the survey.json `uav-insar survey --out` writes") from None
    if abs(survey.speed_mps - params.speed) > 1e-9 * max(1.0, params.speed):
        raise ValueError(f"survey_file: {path[:80]!r} was planned at {survey.speed_mps:g} m/s, "
                         f"speed_mps is {params.speed:g}; expected the same (set speed_mps, "
                         "for the bridges too)")
    return survey


class SurveyRun:
    """See the module docstring. `republish()` publishes the planner's current plan again
    (on the strip `leg()` now names); `clock(leg)` is the pass start published for `leg`;
    `lost()` the UAVs the swarm watch declared lost."""

    def __init__(self, node: Node, survey: SurveyFile, republish: Callable[[], None],
                 clock: Callable[[SurveyLeg], PassClock | None],
                 lost: Callable[[], set[int]]) -> None:
        self._node, self._survey = node, survey
        self._republish, self._clock, self._lost = republish, clock, lost
        self._flight = SurveyFlight(tuple(tuple(s) for s in survey.sorties),
                                    {s.index: s.track.length_m for s in survey.strips})
        self._strips = {s.index: s for s in survey.strips}
        self._lock = threading.Lock()
        self._state = SurveyState()
        self._fly: Fly | None = None
        self._leg: SurveyLeg | None = None
        self._formation: tuple | None = None  # the points last published on the strip
        self._lost_seen: frozenset[int] = frozenset()
        node.create_timer(TICK_PERIOD_S, self._tick)

    # --- what the planner publishes --------------------------------------------------------
    def on_publish(self, plan: Plan, params: Params) -> tuple[SurveyLeg, Plan]:
        """The strip `plan` is published on now, and `plan` with that strip's power schedule;
        the first plan begins the survey, one that changes the formation mid-strip
        interrupts it."""
        with self._lock:
            if self._state.phase is Phase.IDLE:
                self._apply(step(self._state, Begin(), self._flight))
            points = tuple(map(tuple, plan.formation.tolist()))
            if self._formation is not None and not _same(points, self._formation):
                self._apply(step(self._state, Interrupted("the plan changed the formation"),
                                 self._flight))
            self._formation = points
            leg = self._leg_of(plan)
        strip = self._strips[leg.strip]
        planned, _ = strip_plan(params, plan, strip, self._survey.station_ne_m)
        return leg, replace(plan, p_com_w=planned.p_com_w)

    def _leg_of(self, plan: Plan) -> SurveyLeg:
        fly = self._fly
        strip = self._strips[fly.strip]
        x0 = float(plan.formation[0, 0])
        self._leg = SurveyLeg(fly.strip, fly.sortie, fly.last, strip.frame(x0),
                              strip.track.length_m, fly.attempt, self._survey.station_ne_m)
        return self._leg

    # --- the run -------------------------------------------------------------------------
    def _apply(self, result) -> list[Reply]:
        """Adopt a step's state; say its lines; return its replies (call with the lock)."""
        self._state, actions = result
        log = self._node.get_logger()
        for action in actions:
            if isinstance(action, Fly):
                self._fly = action
                self._formation = None  # a new strip: its formation is the plan's
            elif isinstance(action, Log) and action.level == "warning":
                log.warning(action.text)  # (rclpy: one severity per call site)
            elif isinstance(action, Log):
                log.info(action.text)
        return [a for a in actions if isinstance(a, Reply)]

    def _tick(self) -> None:
        flies = False
        with self._lock:
            before = self._fly
            if self._state.phase in (Phase.TRANSIT, Phase.TURN) and self._leg is not None:
                clock = self._clock(self._leg)
                if clock is not None:
                    self._apply(step(self._state, Started(clock), self._flight))
            lost = frozenset(self._lost())
            if new := sorted(lost - self._lost_seen):
                why = ", ".join(uav_name(k) for k in new) + " lost"
                self._apply(step(self._state, Interrupted(why), self._flight))
            self._lost_seen = lost
            self._apply(step(self._state, Tick(time.time()), self._flight))
            flies = self._fly is not before
        if flies:
            self._republish()

    def next_sortie(self) -> tuple[bool, str]:
        """The operator's ~/next_sortie: (accepted, what happens or why not)."""
        with self._lock:
            before = self._fly
            replies = self._apply(step(self._state, NextSortie(), self._flight))
            flies = self._fly is not before
        if flies:
            self._republish()
        return (replies[0].ok, replies[0].text) if replies else (False, "no answer")

    def status(self) -> published.Status:
        """The `planner: survey` diagnostic status."""
        with self._lock:
            s, fly = self._state, self._fly
        values = [("phase", s.phase.value), ("sortie", str(s.sortie + 1)),
                  ("strip", "" if s.current is None else str(s.current)),
                  ("attempt", "" if fly is None else str(fly.attempt)),
                  ("strips_flown", f"{len(s.flown)}/{len(self._strips)}"),
                  ("flown", ",".join(map(str, s.flown)))]
        text = {Phase.IDLE: "waiting for a plan", Phase.DONE: "survey complete",
                Phase.RETURN: "sortie over: returning; ~/next_sortie when ready"}.get(
            s.phase, f"sortie {s.sortie + 1}, strip {s.current}: {s.phase.value}")
        return published.Status(published.OK, "planner: survey", text, values)


def _same(a: tuple, b: tuple) -> bool:
    """Whether two formations (rows (x, z), NaN for a UAV not flown) are the same."""
    return len(a) == len(b) and all(
        (math.isnan(p[0]) and math.isnan(q[0])) or (abs(p[0] - q[0]) < 1e-6
                                                    and abs(p[1] - q[1]) < 1e-6)
        for p, q in zip(a, b, strict=True))
