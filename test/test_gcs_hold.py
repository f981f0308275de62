"""The bridge core's ground-station hold (mavlink/holds.py) through real MAVLink bytes on
loopback UDP to simulated vehicles (no ROS): the test plays the ground station by calling
`Bridge.gcs_heard` as the ROS side does for each gcs/heartbeat, and falls silent. The bridge
runs its own clock here (pass_start capture): a new plan resumes the pass where it holds."""
from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import closing, contextmanager

import pytest
from mavlink_fakes import MAV, wait_until
from pymavlink import mavutil

from uav_insar_planner.mavlink.bridge import Bridge, BridgeConfig
from uav_insar_planner.mavlink.holds import GcsWatch
from uav_insar_planner.param_specs.nodes import GCS_HEARTBEAT_PERIOD_S
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(60)
TIMEOUT_S = 1.0
FORMATION = [(0.0, 0.0, 12.0)]


class GroundStation:
    """Calls bridge.gcs_heard every heartbeat period while `on` (the planner's heartbeat)."""

    def __init__(self, bridge: Bridge):
        self.bridge, self.on, self._stop = bridge, True, threading.Event()
        self.newer_plan = False  # its heartbeat names a plan the bridge does not fly
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(GCS_HEARTBEAT_PERIOD_S):
            if self.on:
                self.bridge.gcs_heard("gcs/heartbeat from /test", heartbeat=True,
                                      newer_plan=self.newer_plan)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)


def fly(autopilot: str, **config):
    vehicle = SimVehicle(2, "udpin:127.0.0.1:0", autopilot, start_ned=(0.0, 0.0, -12.0),
                         max_speed=10.0, max_accel=10.0, airborne=True)
    vehicle.start()
    bridge = Bridge(BridgeConfig(connections=(f"udpout:127.0.0.1:{vehicle.port}",),
                                 target_sysids=(2,), autopilot=autopilot, speed_mps=2.0,
                                 gcs_timeout_s=TIMEOUT_S, **config))
    bridge.start()
    return vehicle, bridge


@contextmanager
def with_ground(autopilot: str) -> Iterator[tuple[SimVehicle, Bridge, GroundStation]]:
    """`fly`, with the ground station heard; all three stopped on leaving."""
    vehicle, bridge = fly(autopilot)
    ground = GroundStation(bridge)
    try:
        yield vehicle, bridge, ground
    finally:
        ground.close()
        bridge.stop()
        vehicle.stop()


@pytest.mark.parametrize("autopilot,flying,holding", [("ardupilot", "GUIDED", "LOITER"),
                                                      ("px4", "OFFBOARD", "HOLD")])
def test_a_short_silence_rejoins_a_long_one_holds_until_the_pass_resumes_where_it_holds(
        autopilot, flying, holding):
    mode_name = "LOITER" if autopilot == "ardupilot" else "AUTO.LOITER"

    def silence() -> float:
        ground.on = False
        silent_at = time.monotonic()
        assert wait_until(lambda: vehicle.mode == holding, TIMEOUT_S + 1.0), vehicle.mode
        assert bridge.status()[0].phase == f"holding ({mode_name}): ground station silent"
        return time.monotonic() - silent_at

    with with_ground(autopilot) as (vehicle, bridge, ground):
        bridge.set_formation(FORMATION)
        assert wait_until(bridge.track_started, 10.0)
        assert wait_until(lambda: bridge.gcs_state().startswith("heard "), 2.0)
        assert vehicle.mode == flying
        # short: heard again at once, the vehicle a fraction of a metre behind its target
        latency = silence()
        assert latency > TIMEOUT_S - GCS_HEARTBEAT_PERIOD_S  # not before the timeout
        ground.on = True
        assert wait_until(lambda: vehicle.mode == flying, 5.0), vehicle.mode
        sent = bridge.status()[0].setpoints_sent
        assert wait_until(lambda: bridge.status()[0].setpoints_sent > sent + 5, 3.0)
        # long: 2 s of a 2 m/s pass held, more than the 2 m it may catch up
        silence()
        time.sleep(2.0)
        ground.on = True
        assert wait_until(lambda: "cannot keep the pass" in bridge.status()[0].phase, 2.0), \
            bridge.status()[0].phase
        sent = bridge.status()[0].setpoints_sent
        time.sleep(1.0)
        assert vehicle.mode == holding and bridge.status()[0].setpoints_sent == sent
        assert bridge.status()[0].behind
        # a new plan (same formation, new identity): the pass resumes where it holds
        held_y = bridge.status()[0].position_track[1]
        bridge.set_formation(FORMATION)
        target_y = bridge.status()[0].target_track[1]
        assert wait_until(lambda: vehicle.mode == flying, 5.0), vehicle.mode
        assert wait_until(lambda: bridge.status()[0].setpoints_sent > sent + 5, 3.0)
        events = [e.text for e in bridge.drain_events()]
    assert abs(target_y - held_y) < 1.5, (target_y, held_y)  # no sprint to the old clock
    silent = [e for e in events if e.startswith("ground station silent for ")]
    assert len(silent) == 2 and "last heard: gcs/heartbeat from /test" in silent[0], events
    assert sum(e.startswith("ground station heard again") for e in events) == 2, events
    assert sum("rejoins the pass" in e for e in events) == 2, events
    assert any(e.startswith("the pass resumes where the swarm holds") for e in events), events
    print(f"{autopilot}: {holding} {latency:.2f} s after the ground fell silent "
          f"(gcs_timeout_s {TIMEOUT_S:g})")


def test_a_mode_a_pilot_chose_during_the_hold_is_not_taken_back():
    with with_ground("ardupilot") as (vehicle, bridge, ground), closing(mavutil.mavlink_connection(
            f"udpout:127.0.0.1:{vehicle.port}", source_system=255,
            source_component=MAV.MAV_COMP_ID_MISSIONPLANNER)) as pilot:
        bridge.set_formation(FORMATION)
        assert wait_until(lambda: bridge.gcs_state().startswith("heard "), 2.0)
        ground.on = False
        assert wait_until(lambda: vehicle.mode == "LOITER", TIMEOUT_S + 1.0), vehicle.mode
        assert wait_until(lambda: bridge.status()[0].mode == "LOITER", 2.0)  # seen by it
        pilot.mav.command_long_send(2, 1, MAV.MAV_CMD_DO_SET_MODE, 0,
                                    MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 2, 0, 0, 0, 0, 0)
        assert wait_until(lambda: vehicle.mode == "ALT_HOLD", 3.0), vehicle.mode
        time.sleep(1.5)  # the bridge does not fight the pilot: the hold was reached once
        assert vehicle.mode == "ALT_HOLD"
        assert wait_until(lambda: bridge.status()[0].mode == "ALT_HOLD", 2.0)
        ground.on = True
        time.sleep(2 * GCS_HEARTBEAT_PERIOD_S)
        bridge.set_formation(FORMATION)
        time.sleep(1.5)
        assert vehicle.mode == "ALT_HOLD"
        events = [e.text for e in bridge.drain_events()]
    assert any("a pilot switched it): not taken back to GUIDED" in e for e in events), events


def test_heard_again_with_a_plan_not_flown_here_it_holds_until_that_plan_comes():
    """The planner re-planned during the silence (perhaps without this UAV): its heartbeat
    names the new plan, which the lossy radio delivers later. No rejoin to the old plan: the
    vehicle holds, no setpoints, until the new plan is adopted."""
    with with_ground("ardupilot") as (vehicle, bridge, ground):
        bridge.set_formation(FORMATION)
        assert wait_until(bridge.track_started, 10.0)
        assert wait_until(lambda: bridge.gcs_state().startswith("heard "), 2.0)
        ground.on = False
        assert wait_until(lambda: vehicle.mode == "LOITER", TIMEOUT_S + 1.0), vehicle.mode
        ground.newer_plan, ground.on = True, True  # at once: near enough to rejoin the old one
        assert wait_until(lambda: bridge.gcs_state().startswith("heard "), 2.0)
        sent = bridge.status()[0].setpoints_sent
        time.sleep(1.5)
        assert vehicle.mode == "LOITER" and bridge.status()[0].setpoints_sent == sent
        assert "waiting for the pass to resume" in bridge.status()[0].phase
        bridge.set_formation(FORMATION)  # the new plan arrives: it gives the UAV a target
        assert wait_until(lambda: vehicle.mode == "GUIDED", 5.0), vehicle.mode
        assert wait_until(lambda: bridge.status()[0].setpoints_sent > sent + 5, 3.0)
        events = [e.text for e in bridge.drain_events()]
    waited = [i for i, e in enumerate(events) if e.startswith(
        "the ground station flies a plan not received here yet")]
    rejoined = [i for i, e in enumerate(events) if "rejoins the pass" in e]
    assert len(waited) == 1 and rejoined and rejoined[0] > waited[0], events
    assert "a new plan: rejoins the pass" in events[rejoined[0]], events


def test_never_heard_is_waiting_not_silent():
    vehicle, bridge = fly("ardupilot")
    try:
        bridge.set_formation(FORMATION)
        assert wait_until(bridge.track_started, 10.0)
        time.sleep(TIMEOUT_S + 0.5)
        assert vehicle.mode == "GUIDED"
        assert bridge.gcs_state() == "waiting (never heard)"
        assert bridge.status()[0].phase != "" and not bridge.status()[0].phase.startswith(
            "holding")
    finally:
        bridge.stop()
        vehicle.stop()


def test_gcs_watch_times_out_once_per_silence():
    watch = GcsWatch(2.0)
    assert watch.check(100.0) is None and watch.state(100.0) == "waiting (never heard)"
    # a plan before the first heartbeat: heard, but silence is not loss until one comes
    assert watch.heard("plan", -5.0) is None and watch.check(-1.0) is None
    assert watch.state(-1.0).startswith("waiting (no gcs/heartbeat yet")
    assert watch.heard("a", 0.0, heartbeat=True) is None
    assert watch.check(2.0) is None  # exactly the timeout: not yet
    why = watch.check(2.5)
    assert why == "ground station silent for 2.5 s (gcs_timeout_s 2; last heard: a)"
    assert watch.check(9.0) is None
    assert watch.state(3.0) == "silent 3.0 s (a)"
    assert watch.heard("b", 4.0) == "ground station heard again (b) after 4.0 s silent"
    assert watch.state(4.5) == "heard 0.5 s ago (b)"
    assert GcsWatch(0.0).check(1e9) is None and GcsWatch(0.0).state(0.0) == "off"


def test_gcs_timeout_below_two_heartbeats_is_refused_with_one_line():
    with pytest.raises(ValueError) as err:
        BridgeConfig(connections=("udpout:127.0.0.1:30001",), target_sysids=(2,),
                     gcs_timeout_s=0.4).validate()
    assert str(err.value).startswith("gcs_timeout_s: value 0.4 is not allowed; expected 0 "
                                     "(off) or at least 1 s")
