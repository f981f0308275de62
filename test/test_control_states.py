"""Whether a vehicle is under the bridge's control (mavlink/control_states.py), stepped
without a bridge: a failsafe, a pilot's mode change or a disarm in the air after the bridge
had it is said once and is final; our own hold and return orders, and a vehicle not yet
ours, are not. With real processes: test_leaving_control.py."""
from __future__ import annotations

from uav_insar_planner.mavlink.control_states import (
    LEFT_PREFIX,
    Control,
    Heard,
    UavControl,
    step,
)


def heard(mode: str = "GUIDED", *, flight: bool | None = None, armed: bool = True,
          airborne: bool = True, taken: bool = True, excused: bool = False) -> Heard:
    return Heard(mode, mode in ("GUIDED", "OFFBOARD") if flight is None else flight, armed,
                 airborne, taken, excused)


def run(*events: Heard) -> tuple[UavControl, list]:
    control, said = UavControl(), []
    for event in events:
        control, tells = step(control, event)
        said += tells
    return control, said


def test_not_ours_until_taken_armed_in_the_flight_mode():
    for event in (heard(taken=False), heard(armed=False), heard("STABILIZE")):
        control, said = run(event, heard("RTL"), heard(armed=False))
        assert control.state is Control.NOT_YET and said == []
    control, said = run(heard())
    assert control.state is Control.FLYING and said == [] and control.phase() == ""


def test_a_failsafe_or_a_pilot_is_said_once_and_is_final():
    for mode in ("RTL", "LAND", "AUTO.LOITER", "AUTO.RTL", "ALT_HOLD"):
        control, said = run(heard(), heard(mode), heard(mode), heard("GUIDED"), heard(mode))
        assert control.state is Control.LEFT and control.why == mode
        assert control.phase() == f"{LEFT_PREFIX}{mode}"
        assert len(said) == 1 and said[0].level == "warn"
        assert said[0].text.startswith(f"out of our control: {mode}: ")
        assert "does not fight" in said[0].text


def test_a_disarm_in_the_air_or_on_the_ground():
    control, said = run(heard(), heard(armed=False))
    assert control.why == "disarmed in the air" and len(said) == 1
    control, _ = run(heard(), heard(armed=False, airborne=False))
    assert control.why == "disarmed on the ground"


def test_our_orders_park_it_and_a_mode_after_them_is_not_ours():
    # the hold order (LOITER), then back into GUIDED: ours all along
    control, said = run(heard(), heard("LOITER", excused=True), heard("LOITER", excused=True),
                        heard())
    assert control.state is Control.FLYING and said == []
    # released while in LOITER (a mission stop's hold): stays parked there, no word
    control, said = run(heard(), heard("LOITER", excused=True), heard("LOITER"))
    assert control.state is Control.PARKED and control.mode == "LOITER" and said == []
    # a pilot switches the parked vehicle elsewhere, or disarms it: out of our control
    control, said = run(heard(), heard("LOITER", excused=True), heard("ALT_HOLD"))
    assert control.why == "ALT_HOLD" and len(said) == 1
    control, said = run(heard(), heard("LOITER", excused=True), heard("LOITER", armed=False))
    assert control.why == "disarmed in the air"
    # the survey's return: RTL, landed and disarmed, all under our order
    control, said = run(heard(), heard("RTL", excused=True),
                        heard("RTL", armed=False, airborne=False, excused=True))
    assert control.state is Control.PARKED and said == []
