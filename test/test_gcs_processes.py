"""Radio loss, UAV side, with real processes: the planner (the ground station) and a bridge
with gcs_timeout_s on a private domain, MAVLink over loopback UDP to a simulated vehicle in
this process. The fault: the planner's process group is frozen (SIGSTOP), so nothing comes
from the ground, then thawed (SIGCONT): the vehicle, held too long to catch up with the pass
clock, says it is behind, and the planner resumes the pass where it holds. And the planner
killed (SIGKILL) and started again mid-pass: the new one resumes the pass where the swarm
holds, never on the dead planner's clock, and no vehicle flies faster than the pass."""
from __future__ import annotations

import math
import os
import re
import signal
import threading
import time

import pytest
from clean_stop import assert_clean, stop_and_read
from diagnostic_msgs.msg import DiagnosticStatus
from std_srvs.srv import Trigger

from uav_insar_planner.ros.start_states import RESTARTED_DELAY_S
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(90)
GCS_TIMEOUT_S = 1.5
STATUS = "mavlink_bridge: uav0"


def bridge_status(w):
    found = [s for m in w.diagnostics for s in m.status if s.name == STATUS]
    return (found[-1], {kv.key: kv.value for kv in found[-1].values}) if found else (None, {})


def test_a_frozen_planner_holds_the_vehicle_then_resumes_the_pass_where_it_holds(watcher,
                                                                                 procs):
    w = watcher
    # the whole swarm (the pass starts once every flown UAV is there); uav0 is watched
    swarm = [SimVehicle(2 + k, "udpin:127.0.0.1:0", "ardupilot",
                        start_ned=(0.0, 10.0 * k, -40.0), max_speed=20.0, max_accel=10.0,
                        airborne=True) for k in range(3)]
    for v in swarm:
        v.start()
    vehicle = swarm[0]
    planner = procs("planner", "-p", "capture_radius_m:=0.0")  # the pass starts at once
    links = ", ".join(f"'udpout:127.0.0.1:{v.port}'" for v in swarm)
    bridge = procs("mavlink_bridge", "-p", f"connections:=[{links}]",
                   "-p", "target_sysids:=[2, 3, 4]", "-p", "speed_mps:=2.0",
                   "-p", f"gcs_timeout_s:={GCS_TIMEOUT_S}")
    everyone = [planner, bridge]
    try:
        def flying():
            status, values = bridge_status(w)
            return (status is not None and status.level == DiagnosticStatus.OK
                    and values["gcs"].startswith("heard ") and vehicle.mode == "GUIDED"
                    and vehicle.setpoints_accepted > 20
                    and vehicle.velocity_ned[0] > 0.5)  # on the pass: past its run-in's hover

        assert w.spin_until(flying, 40.0, everyone), (bridge_status(w), vehicle.mode)
        os.killpg(planner.pid, signal.SIGSTOP)
        frozen_at = time.monotonic()
        assert w.spin_until(lambda: vehicle.mode == "LOITER", GCS_TIMEOUT_S + 1.0, [bridge]), \
            vehicle.mode
        latency = time.monotonic() - frozen_at
        assert w.spin_until(lambda: bridge_status(w)[0].level == DiagnosticStatus.WARN, 2.0)
        status, values = bridge_status(w)
        assert "holding (LOITER): ground station silent" in status.message, status.message
        assert values["gcs"].startswith("silent "), values["gcs"]

        w.spin_until(lambda: False, 2.0)  # 2 s of a 2 m/s pass: farther than it may catch up
        held_y = vehicle.position_ned[0]  # (track bearing 0: along track is north)
        os.killpg(planner.pid, signal.SIGCONT)
        thawed_at = time.monotonic()
        assert w.spin_until(lambda: vehicle.mode == "GUIDED", 10.0, everyone), vehicle.mode
        resumed = time.monotonic() - thawed_at
        accepted = vehicle.setpoints_accepted
        assert w.spin_until(lambda: vehicle.setpoints_accepted > accepted + 10, 3.0)
        assert w.spin_until(lambda: bridge_status(w)[0].level == DiagnosticStatus.OK, 5.0)
        # from where it held, not from where the old clock would have it: no sprint
        _, values = bridge_status(w)
        target_y = float(values["target_track_m"].split()[1])
        assert target_y - held_y < 2.0 * 4.0, (target_y, held_y)
        # a re-plan now keeps the resumed clock
        answer = w.call(Trigger, "/planner/replan", Trigger.Request(), timeout=10.0)
        assert answer is not None and answer.success
        w.spin_until(lambda: False, 2.0)
        assert vehicle.mode == "GUIDED"
    finally:
        os.killpg(planner.pid, signal.SIGCONT)
        codes, outs = stop_and_read(everyone)
        for v in swarm:
            v.stop()
    assert_clean(everyone, codes, outs)
    planner_out, out = outs
    silent = [line for line in out.splitlines() if "ground station silent for" in line]
    assert len(silent) == 1 and "last heard: " in silent[0], out
    assert "stopping the setpoints and commanding LOITER to every vehicle" in silent[0]
    assert "cannot keep the pass, keeps holding" in out
    assert "rejoins the pass" in out and "LOITER -> GUIDED" in out
    assert "resuming the pass where the swarm is" in planner_out
    print(f"LOITER {latency:.2f} s after SIGSTOP (gcs_timeout_s {GCS_TIMEOUT_S:g}); GUIDED "
          f"{resumed:.2f} s after SIGCONT, from where it held")


def test_a_planner_killed_and_started_again_resumes_where_the_swarm_holds(watcher, procs):
    w = watcher
    speed = 2.0
    swarm = [SimVehicle(2 + k, "udpin:127.0.0.1:0", "ardupilot",
                        start_ned=(0.0, 10.0 * k, -40.0), max_speed=20.0, max_accel=10.0,
                        airborne=True) for k in range(3)]
    for v in swarm:
        v.start()
    fastest = [0.0]
    watching = threading.Event()

    def watch_speed() -> None:  # the vehicles' true speed, from the kill to the end
        while not watching.is_set():
            fastest[0] = max([fastest[0]] + [math.hypot(*v.velocity_ned[:2]) for v in swarm])
            time.sleep(0.02)

    planner = procs("planner", "-p", "capture_radius_m:=0.0")
    links = ", ".join(f"'udpout:127.0.0.1:{v.port}'" for v in swarm)
    bridge = procs("mavlink_bridge", "-p", f"connections:=[{links}]",
                   "-p", "target_sysids:=[2, 3, 4]", "-p", f"speed_mps:={speed}",
                   "-p", f"gcs_timeout_s:={GCS_TIMEOUT_S}")
    again = None
    try:
        def along() -> float:  # uav0's distance along the pass (bearing 0: north)
            _, values = bridge_status(w)
            return float(values["position_track_m"].split()[1]) if values.get(
                "position_track_m") else -1e9

        assert w.spin_until(lambda: along() > 6.0, 40.0, [planner, bridge]), bridge_status(w)
        threading.Thread(target=watch_speed, daemon=True).start()
        os.killpg(planner.pid, signal.SIGKILL)
        assert w.spin_until(lambda: all(v.mode == "LOITER" for v in swarm),
                            GCS_TIMEOUT_S + 2.0, [bridge]), [v.mode for v in swarm]
        w.spin_until(lambda: False, 2.0)  # held: 4+ m of a 2 m/s pass behind its old clock
        held = along()
        again = procs("planner", "-p", "capture_radius_m:=0.0")
        assert w.spin_until(lambda: all(v.mode == "GUIDED" for v in swarm), 30.0,
                            [again, bridge]), [v.mode for v in swarm]
        # the resume waits for every bridge to find the new planner, then flies the pass again
        w.spin_until(lambda: False, RESTARTED_DELAY_S + 4.0)
        flown = along() - held
        _, confirmed = bridge_status(w)  # the start the bridge says it flies
    finally:
        watching.set()
        stopped = [p for p in (bridge, again) if p is not None]
        codes, outs = stop_and_read(stopped)
        for v in swarm:
            v.stop()
    assert_clean(stopped, codes, outs)
    log = outs[1]
    assert "resuming the pass where the swarm is" in log, log[-3000:]
    # the bridge confirmed the new planner's start on /diagnostics: it was not moved
    instant = float(re.search(r"resuming the pass where the swarm is: .*wall clock ([\d.]+)",
                              log)[1])
    assert float(confirmed["pass_start"]) == pytest.approx(instant, abs=2e-3), confirmed
    assert "the resumed pass waits" not in log, log[-3000:]
    assert 0.0 < flown < speed * 4.0 + 1.0, flown  # on from where it held, at the pass's speed
    assert fastest[0] <= speed + 1.0, fastest[0]
    print(f"planner started again: resumed from {held:.1f} m, fastest vehicle "
          f"{fastest[0]:.2f} m/s (pass {speed:g} m/s)")
