"""The bridge steps back from a real ArduCopter that a pilot takes (issue 41, item 2): one
ArduCopter SITL (../shared/sitl/, skipped where absent), armed, taken off and flown by the
bridge (arm_and_takeoff, no ROS); then a ground station on the copter's SERIAL1 (this test,
real MAVLink bytes: the fault's only injection) switches it to LOITER, as a pilot would. The
bridge says `out of our control: LOITER` within a second of the first heartbeat that shows it
and sends the copter no command and no setpoint afterwards (every command it sends is
recorded by a subclass that only watches). ROS and the planner's re-plan:
test_leaving_control.py on the SITL-style vehicles.

Ports 34060-34064 (SERIAL0 TCP 34060, SERIAL1 34062; this file's own).
"""
from __future__ import annotations

import subprocess
import time
from collections.abc import Sequence

import process_group
import pytest
from mavlink_fakes import wait_until
from pymavlink import mavutil
from sitl_autopilot import ARDUCOPTER, sitl_command

from uav_insar_planner.autopilots.profiles import copter_mode
from uav_insar_planner.mavlink.bridge import Bridge, BridgeConfig
from uav_insar_planner.mavlink.link import MAV
from uav_insar_planner.mavlink.supervision import WatchedVehicle

pytestmark = [
    pytest.mark.timeout(240),
    pytest.mark.skipif(not ARDUCOPTER.exists(),
                       reason=f"ArduCopter SITL not found at {ARDUCOPTER}: a user's machine "
                              "does not have it"),
]
BASE_PORT, SYSID = 34060, 2


class WatchedBridge(Bridge):
    """The bridge, every command it sends kept with its monotonic time (nothing changed)."""

    def __init__(self, config: BridgeConfig) -> None:
        self.sent: list[tuple[float, int]] = []
        super().__init__(config)

    def _send_command(self, v: WatchedVehicle, command: int, params: Sequence[float],
                      confirmation: int = 0) -> None:
        self.sent.append((time.monotonic(), command))
        super()._send_command(v, command, params, confirmation)


def test_a_pilot_takes_a_real_arducopter_and_the_bridge_steps_back(tmp_path):
    parm = tmp_path / "none.parm"
    parm.write_text("")
    log = open(tmp_path / "sitl.log", "w")  # noqa: SIM115 - closed below
    sitl = subprocess.Popen(sitl_command(SYSID, parm, BASE_PORT), cwd=tmp_path, stdout=log,
                            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            start_new_session=True)  # its group killed below
    gcs = None
    try:
        time.sleep(1.0)  # SERIAL0 listens
        bridge = WatchedBridge(BridgeConfig(
            connections=(f"tcp:127.0.0.1:{BASE_PORT}",), target_sysids=(SYSID,),
            arm_and_takeoff=True, speed_mps=2.0, track_duration_s=60.0))
        with bridge:
            bridge.set_formation([(0.0, 0.0, 8.0)])
            events: list[str] = []

            def under_control() -> bool:
                events.extend(e.text for e in bridge.drain_events())
                return any("armed and under our control" in e for e in events)

            assert wait_until(under_control, 150.0, 0.1), events[-10:]
            time.sleep(3.0)
            assert bridge.status()[0].mode == "GUIDED" and not bridge.status()[0].out_of_control
            gcs = mavutil.mavlink_connection(f"tcp:127.0.0.1:{BASE_PORT + 2}",
                                             source_system=255, source_component=190)
            loiter = copter_mode("LOITER")
            shown: list[float] = []
            end = time.monotonic() + 15.0
            while not shown and time.monotonic() < end:
                gcs.mav.command_long_send(SYSID, 1, MAV.MAV_CMD_DO_SET_MODE, 0,
                                          float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED),
                                          *loiter.set_params, 0, 0, 0, 0, 0)
                until = time.monotonic() + 1.0
                while time.monotonic() < until:
                    hb = gcs.recv_match(type="HEARTBEAT", blocking=True, timeout=0.1)
                    if hb is not None and hb.get_srcSystem() == SYSID and \
                            loiter.shown_by(hb.custom_mode):
                        shown.append(time.monotonic())
                        break
            assert shown, "the copter never showed LOITER"
            assert wait_until(lambda: bridge.status()[0].out_of_control, 3.0, 0.01)
            said = time.monotonic()
            sent_setpoints = bridge.status()[0].setpoints_sent
            time.sleep(4.0)
            status = bridge.status()[0]
            events.extend(e.text for e in bridge.drain_events())
    finally:
        if gcs is not None:
            gcs.close()
        process_group.kill_group(sitl)
        log.close()
    assert said - shown[0] < 1.0, said - shown[0]
    assert status.phase == status.out_of_control == "out of our control: LOITER"
    assert sum("out of our control: LOITER" in e for e in events) == 1, events[-10:]
    assert [c for t, c in bridge.sent if t >= shown[0]] == []
    assert status.setpoints_sent == sent_setpoints and status.mode == "LOITER"
