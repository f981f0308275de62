"""A survey flown by three ArduCopter SITL copters on four hosts, in wind: the flight
test_sitl_survey.py asserts. Not a test file.

The hosts and the field are test/sitl_hosts.py's (network namespaces on the lossy switch, 5 m/s
of turbulent wind across the strips, GNSS noise, one stack per UAV: SITL, bridge with
arm_and_takeoff, agent on its autopilot's positions; the planner and the recorder on the
ground). The planner flies test/survey_field.py's survey (`survey_file`): sortie 1 is strips 0
and 1, a turn between them, then every copter returns to launch and lands; once all have
landed, a service call on the ground host (~/next_sortie) lets sortie 2 go: the copters arm and
take off again and fly strip 2.

The copters take off from three places (TAKE_OFFS, metres north and east of the survey's
home): each SITL is started at its own home, so its local NED is its own, and its bridge is
told where the survey's home lies in it (origin_ned_m).
"""
from __future__ import annotations

import math
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import sitl_autopilot as sitl
import sitl_hosts as hosts
from netlab_swarm import Output, stop_recorder, wait_for
from survey_field import write_survey

from uav_insar_planner.demo.processes import executable
from uav_insar_planner.mission_file.qgc_plan import Home
from uav_insar_planner.param_specs.nodes import FIRST_SYSID
from uav_insar_planner.survey.survey_file import SurveyFile
from uav_insar_planner.swarm import uav_name
from uav_insar_sim.netlab.dds_env import dds_env
from uav_insar_sim.netlab.lab import NetLab

TAKE_OFFS = {0: (-25.0, 10.0), 1: (0.0, -20.0), 2: (60.0, 40.0)}  # behind, beside, ahead
CALL_NEXT_SORTIE = """
import rclpy, sys
from std_srvs.srv import Trigger
rclpy.init()
node = rclpy.create_node("operator")
client = node.create_client(Trigger, "/planner/next_sortie")
if not client.wait_for_service(timeout_sec=30.0):
    sys.exit("no /planner/next_sortie")
future = client.call_async(Trigger.Request())
rclpy.spin_until_future_complete(node, future, timeout_sec=30.0)
result = future.result()
print("next_sortie:", result.success, result.message, flush=True)
sys.exit(0 if result.success else 1)
"""


@dataclass
class SurveyFlight:
    """What the flight left: outputs by name, the bag, the survey, its file, stage times."""

    out: dict[str, Output]
    bag: Path
    survey: SurveyFile
    survey_path: Path
    times: dict[str, float] = field(default_factory=dict)


def copter_home(k: int) -> str:
    """Copter k's --home: the survey's home moved TAKE_OFFS[k]."""
    lat, lon, alt, heading = (float(v) for v in sitl.HOME.split(","))
    n, e = TAKE_OFFS[k]
    return (f"{lat + n / 111_320.0:.7f},{lon + e / (111_320.0 * math.cos(math.radians(lat))):.7f}"
            f",{alt:g},{heading:g}")


def start_hosts(lab: NetLab, domain: int, workdir: Path) -> SurveyFlight:
    parm, params = hosts.write_inputs(workdir)
    lat, lon, alt, _ = (float(v) for v in sitl.HOME.split(","))
    survey_path, survey = write_survey(workdir, Home(lat, lon, alt))
    env = dds_env("subnet", [], {**hosts.base_env(), "ROS_DOMAIN_ID": str(domain)})
    flight = SurveyFlight({}, workdir / "bag", survey, survey_path)
    ros = ["--ros-args", "--params-file", str(params)]

    def start(host: str, name: str, cmd: list[str]) -> None:
        proc = lab.start(host, cmd, env=env, stderr=subprocess.STDOUT)
        flight.out[name] = Output(proc, name)

    for k in hosts.UAVS:
        host, sysid = uav_name(k), FIRST_SYSID + k
        copter = workdir / f"copter{k}"
        copter.mkdir()
        with open(copter / "sitl.log", "w") as log:
            lab.start(host, sitl.sitl_command(sysid, parm, home=copter_home(k)), cwd=copter,
                      stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        n, e = TAKE_OFFS[k]  # the survey's home in this copter's local NED
        start(host, f"bridge{k}", [
            *executable("mavlink_bridge"), *ros, "-r", f"__ns:=/{host}", "-p", f"uav_id:={k}",
            "-p", f"connections:=['tcp:127.0.0.1:{hosts.SITL_PORT}']",
            "-p", f"target_sysids:=[{sysid}]", "-p", "arm_and_takeoff:=true",
            "-p", f"origin_ned_m:=[{-n}, {-e}, 0.0]"])
        start(host, f"agent{k}", [*executable("agent"), *ros, "-r", f"__ns:=/{host}",
                                  "-p", f"uav_id:={k}", "-p", "position_source:=autopilot"])
    start("ground", "planner", [*executable("planner"), *ros, "-p",
                                f"survey_file:={survey_path}"])
    start("ground", "recorder", [*executable("uav-insar"), "record", str(flight.bag)])
    return flight


def fly(lab: NetLab, domain: int, workdir: Path, timeout_s: float = 560.0) -> SurveyFlight:
    """The survey's two sorties; AssertionError with the logs when one did not end."""
    t0 = time.monotonic()
    flight = start_hosts(lab, domain, workdir)
    out = flight.out
    procs = [o.proc for o in out.values()]

    def logs() -> str:
        return "\n".join(f"== {n}\n{o.text()[-2500:]}" for n, o in out.items())

    def all_say(what: str, names: str) -> bool:
        return all(out[f"{names}{k}"].first(what) for k in hosts.UAVS)

    try:
        end = t0 + timeout_s
        ok = wait_for(lambda: all_say("landed and disarmed", "bridge"),
                      end - time.monotonic(), procs)
        assert ok, "sortie 1 did not end with every copter landed:\n" + logs()
        flight.times["sortie1_landed_s"] = time.monotonic() - t0
        call = lab.start("ground", [sys.executable, "-c", CALL_NEXT_SORTIE],
                         env=dds_env("subnet", [], {**hosts.base_env(),
                                                    "ROS_DOMAIN_ID": str(domain)}),
                         stderr=subprocess.STDOUT)
        out["operator"] = Output(call, "operator")
        ok = wait_for(lambda: out["planner"].first("survey complete"), end - time.monotonic(),
                      procs)
        assert ok, "sortie 2 did not complete:\n" + logs()
        flight.times["survey_complete_s"] = time.monotonic() - t0
        ok = wait_for(lambda: all(out[f"bridge{k}"].text().count("landed and disarmed") == 2
                                  for k in hosts.UAVS), end - time.monotonic(), procs)
        assert ok, "sortie 2 did not end with every copter landed:\n" + logs()
        flight.times["sortie2_landed_s"] = time.monotonic() - t0
        time.sleep(3 * hosts.FAST_DDS_HEARTBEAT_S + 1.0)
        stop_recorder(out)
    finally:
        for name, o in out.items():
            (workdir / f"{name}.log").write_text(o.text() + "\n")
    return flight
