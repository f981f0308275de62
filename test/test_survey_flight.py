"""A survey flown by the nodes (issue 40, item 2), on real processes on localhost: the planner
with `survey_file`, three `uav-insar-vehicle` simulators on the ground at three places
(behind, beside and ahead of the first strip), one stack per UAV (bridge with
arm_and_takeoff, agent on its autopilot's positions) in /uavK.

Three strips in two sorties: strips 0 and 1 (a turn between them), then the vehicles return
and land; the operator's ~/next_sortie is refused while a sortie flies and accepted once it is
over; the vehicles arm and take off again and fly strip 2. Every agent reports every strip's
slots, all of them flown at v_y; the offload messages name the strip of each slot.

Ports 33100-33199 (this file's own), a private ROS domain (conftest `ros_domain`).
"""
from __future__ import annotations

import os
import re
import subprocess

import process_group
import pytest
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger
from survey_field import write_survey

from uav_insar_planner.demo.processes import executable, start_process
from uav_insar_planner.mission_file.qgc_plan import Home
from uav_insar_planner.ros import topics
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, uavs
from uav_insar_sim.vehicle.telemetry import SITL_HOME

UAVS = uavs(DEFAULT_NUM_UAVS)
pytestmark = pytest.mark.timeout(420)
VEHICLE_PORTS = (33110, 33120, 33130)
SYSIDS = (2, 3, 4)
# on the ground, metres north, east of the home: behind, beside and ahead of strip 0's entry
TAKE_OFFS = ((-25.0, 10.0), (0.0, -20.0), (60.0, 40.0))


def start(name: str, *args: str) -> subprocess.Popen:
    return start_process([*executable(name), *args], dict(os.environ, PYTHONUNBUFFERED="1"))


def stop(proc: subprocess.Popen) -> str:
    process_group.interrupt_group(proc)
    return proc.stdout.read()


def test_the_nodes_fly_a_survey_strip_after_strip_and_sortie_after_sortie(watcher, tmp_path):
    path, survey = write_survey(tmp_path, Home(*SITL_HOME))
    vehicles = [start("uav-insar-vehicle", "--sysid", str(s), "--listen",
                      f"udpin:127.0.0.1:{port}", "--speed", "12", "--accel", "5",
                      "--start-ned", str(n), str(e), "0")
                for (n, e), s, port in zip(TAKE_OFFS, SYSIDS, VEHICLE_PORTS, strict=True)]
    bridges = [start("mavlink_bridge", "--ros-args", "-r", f"__ns:=/uav{k}",
                     "-p", f"uav_id:={k}", "-p", f"connections:=['udpout:127.0.0.1:{port}']",
                     "-p", f"target_sysids:=[{s}]", "-p", "arm_and_takeoff:=true",
                     "-p", "velocity_feedforward:=true")
               for k, s, port in zip(UAVS, SYSIDS, VEHICLE_PORTS, strict=True)]
    agents = [start("agent", "--ros-args", "-r", f"__ns:=/uav{k}", "-p", f"uav_id:={k}",
                    "-p", "position_source:=autopilot") for k in UAVS]
    planner = start("planner", "--ros-args", "-p", f"survey_file:={path}")
    strips_of: dict[int, list[int]] = {k: [] for k in UAVS}
    for k in UAVS:
        watcher.node.create_subscription(
            Float64MultiArray, "/" + topics.offload(k),
            lambda msg, k=k: strips_of[k].append(int(msg.data[4])), topics.RATE_DEPTH)
    everyone = [*vehicles, *bridges, *agents, planner]

    def survey_status() -> dict:
        for msg in reversed(watcher.diagnostics):
            for s in msg.status:
                if s.name == "planner: survey":
                    return {kv.key: kv.value for kv in s.values}
        return {}

    def disarmed_all() -> bool:
        seen = {}
        for msg in watcher.diagnostics[-20:]:
            for s in msg.status:
                if s.name.startswith("mavlink_bridge: uav"):
                    seen[s.name] = {kv.key: kv.value for kv in s.values}.get("armed")
        return len(seen) == len(UAVS) and all(v == "False" for v in seen.values())

    next_sortie = "/planner/next_sortie"
    try:
        assert watcher.spin_until(lambda: survey_status().get("phase") == "strip", 120.0,
                                  everyone), survey_status()
        early = watcher.call(Trigger, next_sortie, Trigger.Request())
        assert watcher.spin_until(lambda: survey_status().get("phase") == "return", 150.0,
                                  everyone), survey_status()
        assert survey_status()["strips_flown"] == "2/3"
        assert watcher.spin_until(disarmed_all, 120.0, everyone), "the vehicles did not land"
        accepted = watcher.call(Trigger, next_sortie, Trigger.Request())
        assert watcher.spin_until(lambda: survey_status().get("phase") == "done", 180.0,
                                  everyone), survey_status()
        watcher.spin_until(lambda: False, 1.0, everyone)
    finally:
        outs = [stop(p) for p in everyone]
    planner_out, agent_outs = outs[-1], outs[len(vehicles) + len(bridges):-1]
    bridge_outs = outs[len(vehicles):len(vehicles) + len(bridges)]
    assert not early.success and "is being flown" in early.message, early.message
    assert accepted.success, accepted.message
    assert "survey complete: 3 strips flown" in planner_out, planner_out[-3000:]
    for k, out in zip(UAVS, agent_outs, strict=True):
        for strip, what in ((0, "strip 1 of sortie 1"), (1, "strip 2 of sortie 1 (its last)"),
                            (2, "strip 3 of sortie 2 (its last)")):
            n = survey.num_slots[strip]
            done = re.search(rf"uav{k}: {re.escape(what)} complete: (\d+) slots flown, "
                             r"(\d+) at the planned speed.*", out)
            assert done, f"uav{k} {what}:\n{out[-3000:]}"
            assert (int(done[1]), int(done[2])) == (n, n), done[0]
        assert strips_of[k] == [0] * survey.num_slots[0] + [1] * survey.num_slots[1] + [
            2] * survey.num_slots[2], strips_of[k]
    for out in bridge_outs:
        assert out.count("return to launch") == 2, out[-3000:]
        assert "ERROR" not in out, out[-3000:]


@pytest.mark.parametrize("case", ["missing", "not a survey", "another speed"])
def test_a_survey_file_the_planner_cannot_fly_is_one_line_and_exit_2(ros_domain, tmp_path,
                                                                     case):
    path, _ = write_survey(tmp_path, Home(*SITL_HOME))
    args = ["-p", f"survey_file:={path}"]
    if case == "missing":
        args = ["-p", f"survey_file:={tmp_path / 'nothing.json'}"]
    elif case == "not a survey":
        (tmp_path / "area.json").write_text('{"type": "Polygon", "coordinates": []}')
        args = ["-p", f"survey_file:={tmp_path / 'area.json'}"]
    else:
        args += ["-p", "speed_mps:=3.0"]
    planner = start("planner", "--ros-args", *args)
    code = planner.wait(timeout=60)
    out = planner.stdout.read()
    errors = [line for line in out.splitlines() if "survey_file" in line]
    assert code == 2 and len(errors) == 1, out
    assert ("4.3 m/s" in errors[0]) == (case == "another speed"), errors[0]
