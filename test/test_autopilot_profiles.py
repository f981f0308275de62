"""The autopilot profile tables (autopilots/profiles.py, uav_insar_sim/vehicle/profiles.py):
each row is named by its key, the simulator's rows are flavours the bridge knows, modes survive
the trip through HEARTBEAT.custom_mode, and a bad flavour or row is refused in one line."""
from __future__ import annotations

from dataclasses import replace

import pytest

from uav_insar_planner.autopilots.profiles import AUTOPILOTS, PROFILES, profile
from uav_insar_planner.param_specs.nodes import BRIDGE_SPECS
from uav_insar_sim.vehicle.profiles import VEHICLE_PROFILES, vehicle_profile


def test_each_row_is_named_by_its_key_and_the_bridge_offers_every_flavour():
    assert all(p.name == name for name, p in PROFILES.items())
    assert all(v.autopilot is PROFILES[name] for name, v in VEHICLE_PROFILES.items())
    assert set(VEHICLE_PROFILES) <= set(AUTOPILOTS)
    spec = next(s for s in BRIDGE_SPECS if s.name == "autopilot")
    assert spec.choices == AUTOPILOTS and spec.default in AUTOPILOTS


@pytest.mark.parametrize("name", sorted(VEHICLE_PROFILES))
def test_the_simulators_modes_round_trip_through_the_heartbeat(name):
    v = vehicle_profile(name)
    for mode in (v.ground_mode, v.autopilot.flight.name, "LAND", "RTL"):
        custom = v.custom_mode(mode)
        assert v.mode_named(custom, (custom >> 16) & 0xFF, (custom >> 24) & 0xFF) == mode
    # the bridge recognises the vehicle's flight and hold modes from its heartbeat
    flight = v.autopilot.flight
    assert flight.shown_by(flight.custom_mode) and not flight.shown_by(v.custom_mode("LAND"))
    assert not v.autopilot.hold.shown_by(flight.custom_mode)


def test_each_flavour_names_its_mav_autopilot_once_as_pymavlink_does():
    """AutopilotProfile.mav_autopilot is both the .plan's firmwareType and the simulator's
    HEARTBEAT.autopilot; the plain ints are pymavlink's MAV_AUTOPILOT values."""
    from uav_insar_planner.mavlink.link import MAV

    assert PROFILES["ardupilot"].mav_autopilot == MAV.MAV_AUTOPILOT_ARDUPILOTMEGA
    assert PROFILES["px4"].mav_autopilot == MAV.MAV_AUTOPILOT_PX4
    assert all(not hasattr(v, "mav_autopilot") for v in VEHICLE_PROFILES.values())


def test_an_unknown_flavour_is_refused_naming_the_allowed_ones():
    with pytest.raises(ValueError, match=r"^autopilot: 'arduplane' is not allowed; expected "
                                         r"one of ardupilot, px4$"):
        profile("ardupilot".replace("pilot", "plane"))
    with pytest.raises(ValueError, match="^autopilot: 'x"):
        vehicle_profile("x" * 100)


def test_arming_steps_out_of_order_or_without_the_mode_are_refused():
    base = profile("px4")
    with pytest.raises(ValueError, match="arming_steps"):
        replace(base, arming_steps=("arm", "mode"))
    with pytest.raises(ValueError, match="arming_steps"):
        replace(base, arming_steps=("wait for position", "arm"))
