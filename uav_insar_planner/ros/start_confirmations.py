"""Whether every flown UAV's bridge has the planner's resumed pass start, and what the planner
does when one has not by its instant.

A pass resumed from the hover (ros/formation_start.py) starts at an instant the planner
chooses, and every flown UAV's bridge must have that start by then: one that hears it late
holds while the others fly on and, more than a second of the pass behind, is re-planned out.
The delivery is not in the planner's hands. A planner started again is a new DDS participant,
each bridge matches its formation/start writer on its own, and over a lossy radio a lost
discovery sample waits for the writer's next heartbeat (3 s in Fast DDS). A CI run at 10 %
loss: one bridge heard the new planner's start 7 s after the others, 1.9 s past its instant,
7.9 m behind, and its UAV was re-planned out.

Each bridge says on /diagnostics which start it flies (value `pass_start`: the instant as the
planner sent it, wall clock). CONFIRM_MARGIN_S before the instant, every flown UAV's bridge
must have reported it within REPORT_FRESH_S. Otherwise the planner moves the start later
(the same offset, the same delay from now) and says which UAVs it waits for: the swarm keeps
holding meanwhile, and bridges take a newer instant as a new start. After the planner's
`start_confirm_wait_s` (20 s: several Fast DDS heartbeat periods) it stops waiting, says so,
and the start stands: a bridge that never hears the planner is then
left behind and re-planned out, as any UAV that cannot keep the pass.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace

from uav_insar_planner.track.pass_clock import same_instant

# Bridges report once a second: a start heard more than this before its instant is confirmed
# by then in most cases; one heard later moves the start by a few seconds, harmlessly.
CONFIRM_MARGIN_S = 0.5
# Bridges report once a second: a report older than this says nothing, of the start a bridge
# flies or of its being behind (formation_start.py).
REPORT_FRESH_S = 3.0

WAIT, CONFIRMED, LATER, GIVE_UP = "wait", "confirmed", "later", "give up"


@dataclass(frozen=True)
class AwaitedStart:
    """A published resumed start awaiting its confirmations: its instant (wall clock, s),
    how long before it it was sent (`delay_s`), when the first instant of this resume was sent
    (monotonic) and how long it waits for them at most (`wait_s`)."""

    start_s: float
    delay_s: float
    since: float
    wait_s: float

    def later(self, wall_now: float) -> AwaitedStart:
        """The same resume `delay_s` from `wall_now` (time.time())."""
        return replace(self, start_s=wall_now + self.delay_s)


def reported_number(value: str | None) -> float | None:
    """A bridge's diagnostic value (its `pass_start` instant [s], its `speed_mps`) as a
    number, None when it reports none or something that is no finite number (nothing is
    confirmed or told by it)."""
    try:
        got = float(value) if value else math.nan
    except ValueError:
        return None
    return got if math.isfinite(got) else None


def unconfirmed(uavs: Iterable[int], reports: Mapping[int, tuple[float, float]],
                start_s: float, now: float) -> list[int]:
    """The UAVs of `uavs` whose bridge has not reported the instant `start_s` (wall clock, s)
    within REPORT_FRESH_S of `now` (monotonic); reports: uav -> (monotonic time, instant)."""
    out = []
    for k in uavs:
        heard = reports.get(k)
        if (heard is None or now - heard[0] > REPORT_FRESH_S
                or not same_instant(heard[1], start_s)):
            out.append(k)
    return sorted(out)


def verdict(awaited: AwaitedStart, uavs: Iterable[int],
            reports: Mapping[int, tuple[float, float]], now: float,
            wall_now: float) -> tuple[str, list[int]]:
    """(what to do, the UAVs not confirmed): WAIT before the check, CONFIRMED when none is
    missing, else LATER, or GIVE_UP past its `wait_s` (module docstring)."""
    start_s = awaited.start_s
    if wall_now < start_s - CONFIRM_MARGIN_S:
        return WAIT, []
    missing = unconfirmed(uavs, reports, start_s, now)
    if not missing:
        return CONFIRMED, []
    return (GIVE_UP if now - awaited.since > awaited.wait_s else LATER), missing
