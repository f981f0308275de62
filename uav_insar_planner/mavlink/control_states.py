"""Whether a vehicle is under the bridge's control, as plain values: `step(control, heard)`
returns the next state and what to tell. No I/O, no clock: `flight_state.FlightState` feeds
it each vehicle's latest heartbeat (`Heard`) and stops its setpoints, mode orders and
arming sequence for a vehicle that left (`Control.LEFT`).

    state     entered by                                        the bridge
    NOT_YET   start; a new sortie (arming and take-off again)   flies it as before
    FLYING    armed in the flight mode (GUIDED / OFFBOARD)      flies it
              once the bridge has it (`Heard.taken`: its
              arming sequence done, or without one a target)
    PARKED    a mode our own orders account for (`excused`:     flies it (its orders do)
              the hold or return order engaged, no target in
              the plan), kept while that mode stays
    LEFT      from FLYING or PARKED: disarmed, or a mode that   nothing: no setpoints, no
              is neither the flight mode nor the parked one,    mode order, no arming; its
              with no order of ours to account for it           phase `out of our control:
              (a failsafe: RTL, LAND, PX4's blind land; a       <mode>` and its `out_of_
              pilot's or a ground station's mode change)        control` value on /diagnostics

LEFT is final for the bridge's life, as a lost UAV is for the planner's mission
(replanning/triggers.py): whoever took the vehicle keeps it; the planner re-plans the others
without it (ros/swarm_watch.py reads `out_of_control`). A vehicle the bridge never had
(NOT_YET) is not watched: its arming sequence reports its own troubles.
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

# What the bridge says of a vehicle that left, before the mode or "disarmed ..." (the phase
# on /diagnostics, the log line and the `out_of_control` value).
LEFT_PREFIX = "out of our control: "


class Control(Enum):
    """One vehicle's control state (the module doc's table)."""

    NOT_YET = "not yet under our control"
    FLYING = "under our control, in the flight mode"
    PARKED = "under our control, in a mode our orders account for"
    LEFT = "out of our control"


@dataclass(frozen=True)
class UavControl:
    """A vehicle's state; `mode` the mode it is parked in (PARKED) and `why` what it left
    into (LEFT: the mode, or "disarmed in the air" / "disarmed on the ground")."""

    state: Control = Control.NOT_YET
    mode: str = ""
    why: str = ""

    @property
    def left(self) -> bool:
        return self.state is Control.LEFT

    def phase(self) -> str:
        """`out of our control: <why>` once LEFT, else ""."""
        return LEFT_PREFIX + self.why if self.left else ""


@dataclass(frozen=True)
class Heard:
    """A vehicle's latest heartbeat as the bridge reads it: its mode's name, whether it is the
    profile's flight mode, armed, airborne (by its position), whether the bridge has it
    (`taken`: arming sequence done, or without one a target to fly) and whether an order of
    ours accounts for its mode (`excused`)."""

    mode: str
    in_flight_mode: bool
    armed: bool
    airborne: bool
    taken: bool
    excused: bool


@dataclass(frozen=True)
class Tell:
    """A line for the log."""

    level: str
    text: str


def step(control: UavControl, heard: Heard) -> tuple[UavControl, list[Tell]]:
    """The state after `heard` and what to tell (the module doc)."""
    state = control.state
    if state is Control.LEFT:
        return control, []
    if state is Control.NOT_YET:
        if heard.taken and heard.armed and heard.in_flight_mode:
            return UavControl(Control.FLYING), []
        return control, []
    if heard.armed and heard.in_flight_mode:
        return UavControl(Control.FLYING), []
    if heard.excused:
        return UavControl(Control.PARKED, mode=heard.mode), []
    if state is Control.PARKED and heard.mode == control.mode and heard.armed:
        return control, []
    why = heard.mode
    if not heard.armed:
        why = "disarmed in the air" if heard.airborne else "disarmed on the ground"
    return UavControl(Control.LEFT, why=why), [Tell("warn", (
        f"{LEFT_PREFIX}{why}: no more setpoints, mode orders or arming from the bridge (it "
        "does not fight the autopilot or the pilot); reported out_of_control so that the "
        "planner re-plans the others without it"))]
