"""The planner's pass start (ros/formation_start.py) as named states and one pure step
function: `step(state, event, now) -> (state, actions)`. No ROS here: the node adapter feeds
it what it heard and executes what it returns, so every decision is testable without a node.

  phase               the data it holds           left for
  NO_PLAN             nothing                     AWAITING_CAPTURE: a plan (NewPlan)
  AWAITING_CAPTURE    the plan, its start points  STARTED: every flown UAV fresh and within
                                                    capture_radius_m of its entry (after
                                                    capture_timeout_s the rest are lost);
                                                  STARTED / RESUME_UNCONFIRMED: all on their
                                                    tracks past the start line (a planner
                                                    started again): resumed from the rearmost
  STARTED             + the published start       RESUME_UNCONFIRMED: every flown UAV behind
                        (`clock`, wall clock)       (resumed from the hover);
                                                  AWAITING_CAPTURE: a plan with another
                                                    y_start (or none flown)
  RESUME_UNCONFIRMED  + the awaited confirmation  STARTED: every flown bridge confirmed the
                        (`awaited`)                 resumed instant, or start_confirm_wait_s
                                                    passed (said); stays, its start moved
                                                    later, while one has not by the instant;
                                                  AWAITING_CAPTURE: as STARTED

Why these four: a start exists or not (`clock`), and a resumed start from the hover is not safe
until every bridge has it (`awaited`, ros/start_confirmations.py): the combinations that occur.

A plan with the same start line as the running pass (`same_line`, a re-plan during the pass)
and the same survey strip (track/leg.py; every strip starts at y = 0 of its own frame) keeps
the state and its start, published again under the new identity; any other goes back to
AWAITING_CAPTURE and the old start is void. While a start runs, the bridges' `behind` reports
are watched (BehindReport): every flown UAV behind resumes the pass from the rearmost; one
behind alone longer than BEHIND_GRACE_S is declared lost. A resume from the hover starts after
the delay (at least RESTARTED_DELAY_S for a restarted planner, whose start some bridges hear
late); a swarm still flying (the rearmost faster than half v_y) is resumed at once on an
instant MOVING_BACKDATE_S in the past, at speed.
"""
from __future__ import annotations

import enum
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

from uav_insar_planner.plan import Vec3
from uav_insar_planner.ros import start_confirmations
from uav_insar_planner.ros.start_capture import POSE_FRESH_S, all_captured, on_track, why_not
from uav_insar_planner.ros.start_confirmations import (
    GIVE_UP,
    LATER,
    REPORT_FRESH_S,
    WAIT,
    AwaitedStart,
)
from uav_insar_planner.swarm import uav_name
from uav_insar_planner.track.leg import SurveyLeg
from uav_insar_planner.track.pass_clock import PassClock, same_line
from uav_insar_planner.track.passes import run_in_m

# Bridges say `behind` once a second on /diagnostics; a swarm held by one silence says it
# within a few seconds of each other, DDS repairs included. Longer alone: it is left behind.
BEHIND_GRACE_S = 4.0
# A swarm still flying is resumed on an instant this far in the past (more than the bridges'
# track.pass_clock.JOIN_GRACE_S): they take it as a running pass and do not ramp up from a hover.
MOVING_BACKDATE_S = 1.0
# A planner started again hears the UAVs' poses before every bridge has found it (DDS
# discovers each direction on its own): a resume from the hover then starts no sooner than
# this (at 10 % loss a bridge heard it 3.4 s late, after start_delay_s 2 s: its UAV was lost).
RESTARTED_DELAY_S = 5.0
# A capture that takes longer than this is said, with who is missing and why, this often: a
# copter's boot and climb take a minute, a vehicle that never arrives must not be silent.
WAIT_LOG_PERIOD_S = 15.0


class Phase(enum.Enum):
    """The pass start's state (module docstring)."""

    NO_PLAN = "no plan"
    AWAITING_CAPTURE = "awaiting capture"
    STARTED = "started"
    RESUME_UNCONFIRMED = "resume unconfirmed"


class PlanIdentity(Protocol):
    """A plan's identity as the start names it (ros/plan_msgs.PlanId): str() is its label."""

    @property
    def label(self) -> str: ...


@dataclass(frozen=True)
class Behind:
    """A UAV its bridge reports `behind`: first and last report (monotonic) and its words."""

    first: float
    last: float
    why: str


@dataclass(frozen=True)
class StartState:
    """The phase and what it holds (module docstring); SI, `clock` on the wall clock."""

    phase: Phase = Phase.NO_PLAN
    plan: PlanIdentity | None = None
    starts: Mapping[int, Vec3] = field(default_factory=dict)  # flown UAV -> its start point
    y_start: float | None = None
    speed_mps: float = 0.0
    length_m: float = 0.0
    leg: SurveyLeg | None = None  # the survey strip the plan flies (None: a single pass)
    clock: PassClock | None = None  # the published start, while this pass lasts
    awaited: AwaitedStart | None = None  # a resumed start not yet confirmed by all
    behind: Mapping[int, Behind] = field(default_factory=dict)
    confirms: Mapping[int, tuple[float, float]] = field(default_factory=dict)  # (heard, start)
    bridge_speeds: Mapping[int, float] = field(default_factory=dict)  # the v_y each flies
    started: frozenset[str] = frozenset()  # labels of the plans this planner started
    wait_told: float = 0.0  # when the wait for a capture was last said (monotonic)
    # when the capture's deadline started (monotonic): the first check that saw a bridge fly
    # one of the plan's UAVs after the plan (None: not yet)
    capture_since: float | None = None

    def __post_init__(self) -> None:
        running = self.phase in (Phase.STARTED, Phase.RESUME_UNCONFIRMED)
        if ((self.plan is None) != (self.phase is Phase.NO_PLAN)
                or (self.clock is not None) != running
                or (self.awaited is not None) != (self.phase is Phase.RESUME_UNCONFIRMED)):
            raise ValueError(f"inconsistent pass start state: {self}")


@dataclass(frozen=True)
class Now:
    """The two clocks, read once: monotonic (poses, reports) and wall (the start)."""

    mono: float
    wall: float


@dataclass(frozen=True)
class NewPlan:
    """The planner published `plan`: start points (NaN: not flown), v_y, pass length."""

    plan: PlanIdentity
    points: Sequence[Vec3]
    speed_mps: float
    length_m: float
    leg: SurveyLeg | None = None  # another strip (or attempt) is another pass


@dataclass(frozen=True)
class BridgeReport:
    """One bridge status heard on /diagnostics: the instant it flies (None: none), its
    `behind` words ("" when not behind) and the plan it flies, heard at `heard` (monotonic)."""

    k: int
    heard: float
    instant: float | None
    behind: str
    plan_label: str
    speed_mps: float | None = None  # the v_y it flies (None: not said)


@dataclass(frozen=True)
class Observed:
    """What the node saw by a check: latest pose per UAV (monotonic time, position), along-track
    speeds, the bridge reports heard since the last check (in order), the lost UAVs, its
    parameters, and whether a bridge flies any of the plan's UAVs (else nothing is said)."""

    poses: Mapping[int, tuple[float, Vec3]]
    speeds: Mapping[int, float]
    reports: Sequence[BridgeReport]
    lost: frozenset[int]
    capture_radius_m: float
    start_delay_s: float
    start_confirm_wait_s: float
    bridged: bool
    capture_timeout_s: float = 0.0  # 0: the capture is waited for for ever


@dataclass(frozen=True)
class Publish:
    """Publish `clock` (wall clock) as the start of `plan` (and repeat it)."""

    clock: PassClock
    plan: PlanIdentity


@dataclass(frozen=True)
class Log:
    level: str  # "info" or "warning"
    text: str


@dataclass(frozen=True)
class DeclareLost:
    k: int
    why: str
    by: str = "MAVLink bridge"  # who found it: its bridge (`behind`), or the pass start


Action = Publish | Log | DeclareLost


def step(state: StartState, event: Observed | NewPlan, now: Now
         ) -> tuple[StartState, tuple[Action, ...]]:
    """The next state and what to do, on a check (Observed) or a new plan (module docstring)."""
    if isinstance(event, NewPlan):
        return _on_plan(state, event, now)
    state = _heard(state, event.reports)
    if state.phase is Phase.NO_PLAN:
        return state, ()
    starts = {k: p for k, p in state.starts.items() if k not in event.lost}
    if state.phase is Phase.AWAITING_CAPTURE:
        return _await_capture(state, event, starts, now)
    behind, everyone, left = _behind_now(state, event.poses, starts, now.mono)
    state, actions = _confirm(replace(state, behind=behind), starts, now)
    if everyone is not None:
        state, more = _resume(state, everyone, event.start_delay_s, event.start_confirm_wait_s,
                              "every flown UAV holds behind its target", now)
        actions += more
    # (the bridge's words: "... cannot keep the pass")
    return state, actions + tuple(DeclareLost(k, why) for k, why in left)


def _on_plan(state: StartState, new: NewPlan, now: Now
             ) -> tuple[StartState, tuple[Action, ...]]:
    starts = {k: tuple(p) for k, p in enumerate(new.points) if all(map(math.isfinite, p))}
    y_start = next(iter(starts.values()))[1] if starts else None
    plan = dict(plan=new.plan, starts=starts, y_start=y_start, speed_mps=new.speed_mps,
                length_m=new.length_m, leg=new.leg, wait_told=now.mono, capture_since=None)
    if (state.clock is None or y_start is None or state.y_start is None
            or not same_line(y_start, state.y_start) or new.leg != state.leg):
        return replace(state, phase=Phase.AWAITING_CAPTURE, clock=None, awaited=None,
                       **plan), ()
    kept = replace(state, started=state.started | {new.plan.label}, **plan)
    return kept, (Publish(state.clock, new.plan),
                  Log("info", f"pass continues: the same start again for {new.plan}"))


def _heard(state: StartState, reports: Sequence[BridgeReport]) -> StartState:
    """The confirmations and `behind` reports updated by `reports`, in order."""
    if not reports:
        return state
    confirms, behind = dict(state.confirms), dict(state.behind)
    speeds = {**state.bridge_speeds, **{r.k: r.speed_mps for r in reports
                                        if r.speed_mps is not None}}
    for r in reports:
        if r.instant is None:
            confirms.pop(r.k, None)
        else:
            confirms[r.k] = (r.heard, r.instant)
        if r.behind and r.plan_label in state.started:
            first = behind[r.k].first if r.k in behind else r.heard
            behind[r.k] = Behind(first, r.heard, r.behind)
        else:
            behind.pop(r.k, None)
    return replace(state, confirms=confirms, behind=behind, bridge_speeds=speeds)


def _await_capture(state: StartState, seen: Observed, starts: dict[int, Vec3], now: Now
                   ) -> tuple[StartState, tuple[Action, ...]]:
    """AWAITING_CAPTURE on a check: resumed (all on track), started (all captured), or the
    wait said every WAIT_LOG_PERIOD_S."""
    rear = on_track(starts, seen.poses, seen.speeds, now.mono, state.length_m)
    if rear is not None:
        return _resume(state, rear, max(seen.start_delay_s, RESTARTED_DELAY_S),
                       seen.start_confirm_wait_s, "the UAVs are on their tracks past the "
                       "start line (this planner started again?)", now)
    radius, run_in = seen.capture_radius_m, run_in_m(state.speed_mps)
    entries = {k: (x, y - run_in, z) for k, (x, y, z) in starts.items()}
    if state.capture_since is None and seen.bridged:
        state = replace(state, capture_since=now.mono)
    if not all_captured(entries, seen.poses, now.mono, radius):
        waited = now.mono - (now.mono if state.capture_since is None else state.capture_since)
        if 0.0 < seen.capture_timeout_s < waited:
            return _capture_overdue(state, seen, entries, now)
        if now.mono - state.wait_told < WAIT_LOG_PERIOD_S or not seen.bridged:
            return state, ()
        waiting = ", ".join(f"{uav_name(k)} ({w})" for k, w in why_not(
            entries, seen.poses, now.mono, radius, state.bridge_speeds, state.speed_mps).items())
        return replace(state, wait_told=now.mono), (
            Log("info", f"the pass start waits for {waiting}: capture_radius_m {radius:g} "
                        f"({state.plan})"),)
    delay = seen.start_delay_s
    clock = PassClock(now.wall + delay, state.speed_mps, -run_in)  # from the hover
    started = replace(state, phase=Phase.STARTED, clock=clock,
                      started=state.started | {state.plan.label})
    return started, (Publish(clock, state.plan), Log("info", (
        f"every flown UAV ({', '.join(uav_name(k) for k in sorted(starts))}) within "
        f"{radius:g} m of its entry: the pass starts in {delay:g} s, wall clock "
        f"{clock.start_s:.3f} ({state.plan})")))


def _capture_overdue(state: StartState, seen: Observed, entries: dict[int, Vec3], now: Now
                     ) -> tuple[StartState, tuple[Action, ...]]:
    """capture_timeout_s passed: the UAVs not captured are lost, in one line (module doc)."""
    late = [DeclareLost(k, f"not captured after capture_timeout_s {seen.capture_timeout_s:g} s: "
                           f"{w}", "the pass start") for k, w in why_not(entries, seen.poses,
            now.mono, seen.capture_radius_m, state.bridge_speeds, state.speed_mps).items()]
    text = ", ".join(f"{uav_name(a.k)} ({a.why})" for a in late)
    # (the deadline starts again: a re-plan that keeps one out is awaited afresh)
    return replace(state, capture_since=now.mono, wait_told=now.mono), (Log("warning", (
        f"the pass start leaves out {text}: declared lost, the others fly without it once "
        f"re-planned ({state.plan})")), *late)


def _confirm(state: StartState, starts: dict[int, Vec3], now: Now
             ) -> tuple[StartState, tuple[Action, ...]]:
    """A resumed start that some of `starts` has not confirmed by its instant: moved later,
    or waited for no longer (start_confirmations.py)."""
    awaited = state.awaited
    if awaited is None:
        return state, ()
    what, missing = start_confirmations.verdict(awaited, starts, state.confirms, now.mono,
                                                now.wall)
    if what == WAIT:
        return state, ()
    if what != LATER:
        state = replace(state, phase=Phase.STARTED, awaited=None)
        if what != GIVE_UP:
            return state, ()
    who = ", ".join(uav_name(k) for k in missing)
    if what == GIVE_UP:
        return state, (Log("warning", (
            f"the resumed pass starts without its start confirmed by the bridge of {who}: "
            f"waited start_confirm_wait_s {awaited.wait_s:g} s ({state.plan})")),)
    moved = awaited.later(now.wall)
    clock = replace(state.clock, start_s=moved.start_s)
    past = clock.offset_m
    return replace(state, clock=clock, awaited=moved), (Publish(clock, state.plan), Log(
        "warning", f"the resumed pass waits for the bridge of {who}, which has not confirmed "
        f"its start: it starts in {awaited.delay_s:g} s instead, from {past:.2f} m past the "
        f"start line, wall clock {clock.start_s:.3f} ({state.plan})"))


def _behind_now(state: StartState, poses: Mapping[int, tuple[float, Vec3]],
                starts: dict[int, Vec3], now: float
                ) -> tuple[dict[int, Behind], tuple[int, float, float] | None,
                           list[tuple[int, str]]]:
    """(the `behind` reports kept; the resume point when every flown UAV with fresh poses
    reports `behind`, else None; the UAVs left behind alone for BEHIND_GRACE_S, with why)."""
    behind = {k: b for k, b in state.behind.items() if now - b.last <= REPORT_FRESH_S}
    flying = {k: p for k, p in starts.items()
              if k in poses and now - poses[k][0] <= POSE_FRESH_S}
    if not behind or not flying:
        return behind, None, []
    if set(flying) <= set(behind):
        past = {k: poses[k][1][1] - p[1] for k, p in flying.items()}
        rear = min(past, key=past.__getitem__)
        # held in the run-in: from where it holds (not the start line ahead: a sprint)
        return {}, (rear, max(past[rear], -run_in_m(state.speed_mps)), 0.0), []
    if state.awaited is not None:  # one behind may not have heard the resumed start yet
        return behind, None, []
    left = [(k, b.why) for k, b in behind.items()
            if now - b.first > BEHIND_GRACE_S and k in starts]
    return {k: b for k, b in behind.items() if k not in dict(left)}, None, left


def _resume(state: StartState, rear: tuple[int, float, float], delay: float, wait: float,
            why: str, now: Now) -> tuple[StartState, tuple[Action, ...]]:
    """A start from where UAV rear[0] is (rear[1] m past the start line, moving at rear[2]
    m/s): at once if it flies on, after `delay` if it holds; awaiting its confirmations for
    at most `wait` s when from the hover (module docstring)."""
    k, past, speed = rear
    v = state.speed_mps
    moving = v > 0.0 and speed > 0.5 * v
    if moving:  # an instant clearly past: the bridges join it at speed, no ramp
        start_s = now.wall - MOVING_BACKDATE_S
        past = max(0.0, past - v * MOVING_BACKDATE_S)
    else:  # from the hover: the bridges ramp their targets up from there
        start_s = now.wall + delay
    clock = PassClock(start_s, v, past)
    # a resume again while one awaits its confirmations: the wait goes on, not anew
    since = now.mono if state.awaited is None else state.awaited.since
    awaited = None if moving or wait <= 0.0 else AwaitedStart(start_s, delay, since, wait)
    state = replace(state, phase=Phase.STARTED if awaited is None else Phase.RESUME_UNCONFIRMED,
                    clock=clock, awaited=awaited, started=state.started | {state.plan.label})
    when = "at once (still flying)" if moving else f"in {delay:g} s"
    return state, (Publish(clock, state.plan), Log("warning", (
        f"resuming the pass where the swarm is: {why}; from {past:.2f} m past the start "
        f"line ({uav_name(k)}, the rearmost), {when}, at {v:g} m/s, wall clock "
        f"{start_s:.3f} ({state.plan})")))
