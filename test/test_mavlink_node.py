"""End to end through ROS and MAVLink: planner node -> /formation -> mavlink_bridge node ->
MAVLink over UDP -> three SITL-style vehicles -> /uavK/mavlink/pose and /diagnostics.
The nodes run as separate processes on real rclpy,
the vehicles in this process; each test gets its own ROS_DOMAIN_ID (conftest `ros_domain`)."""
import math
import os
import subprocess
import sys

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from process_group import interrupt_group

from uav_insar_planner.param_specs.nodes import FIRST_SYSID
from uav_insar_planner.ros.claims import DISCOVERY_WINDOW_S
from uav_insar_planner.swarm import MAX_UAVS
from uav_insar_sim.vehicle.simulator import SimVehicle

pytestmark = pytest.mark.timeout(90)
SYSIDS = (2, 3, 4)
PY = sys.executable


def ros_env() -> dict:
    """The environment `ros_domain` prepared (private domain, localhost discovery), for children."""
    return dict(os.environ, PYTHONUNBUFFERED="1")


def start(module: str, env: dict, *ros_args: str) -> subprocess.Popen:
    cmd = [PY, "-m", module]
    if ros_args:
        cmd += ["--ros-args", *[a for p in ros_args for a in ("-p", p)]]
    return subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, start_new_session=True)


def finish(proc: subprocess.Popen) -> str:
    interrupt_group(proc)
    return proc.stdout.read()


# one sysid more than the largest swarm has UAVs (swarm.MAX_UAVS)
TOO_MANY = f"target_sysids:={[FIRST_SYSID + k for k in range(MAX_UAVS + 1)]}"


@pytest.mark.parametrize("param", ["setpoint_rate_hz:=1.0", "autopilot:=inav",
                                   "target_sysids:=[2, 2, 3]", "connections:=['nowhere']",
                                   "signing_key_file:=/no/such/key",
                                   "track_bearing_deg:=1e308",
                                   # an empty list has no type in rcl (was a traceback)
                                   "connections:=[]", "target_sysids:=[]",
                                   TOO_MANY])
def test_bad_parameter_exits_2_with_one_line(param, ros_domain):
    proc = start("uav_insar_planner.ros.mavlink_bridge", ros_env(), param)
    try:
        assert proc.wait(timeout=30) == 2
    finally:
        out = finish(proc)
    errors = [line for line in out.splitlines() if "ERROR" in line]
    assert len(errors) == 1 and "Traceback" not in out, out
    assert param.split(":=")[0].split("_")[0] in errors[0] or "connections" in errors[0]
    if param.endswith("[]"):
        assert "value [] is not allowed" in errors[0] and "non-empty list" in errors[0], out
    if param == TOO_MANY:
        assert f"at most {MAX_UAVS}" in errors[0], out


def test_planner_bridge_vehicles_end_to_end(watcher):
    env = ros_env()
    vehicles = [SimVehicle(s, "udpin:127.0.0.1:0", "ardupilot", start_ned=(0.0, 3.0 * k, -40.0),
                           max_speed=20.0, max_accel=10.0, airborne=True)
                for k, s in enumerate(SYSIDS)]
    for v in vehicles:
        v.start()
    ports = ", ".join(f"'udpout:127.0.0.1:{v.port}'" for v in vehicles)
    bridge = start("uav_insar_planner.ros.mavlink_bridge", env, f"connections:=[{ports}]",
                   "target_sysids:=[2, 3, 4]", "speed_mps:=2.0", "velocity_feedforward:=true")
    planner = start("uav_insar_planner.ros.planner", env, "speed_mps:=2.0")  # the bridge's
    spin_until, poses, diags = watcher.spin_until, watcher.mavlink_poses, watcher.diagnostics
    formation = [[(p.position.x, p.position.y, p.position.z) for p in m.poses]
                 for m in watcher.formations]

    def in_formation():
        formation[:] = [[(p.position.x, p.position.y, p.position.z) for p in m.poses]
                        for m in watcher.formations]
        if not formation:
            return False
        for k, v in enumerate(vehicles):
            n, e, d = v.position_ned  # bearing 0, origin 0: (x, y, z) = (E, N, -D)
            x, _, z = formation[-1][k]
            if math.hypot(e - x, -d - z) > 0.5:
                return False
        return True

    try:
        assert spin_until(lambda: watcher.formations, 40.0), "no /formation from the planner"
        assert spin_until(in_formation, 30.0), [v.position_ned for v in vehicles]
        # the pass starts at the planner's formation/start, start_delay_s after its capture
        held = [v.position_ned[0] for v in vehicles]
        assert spin_until(lambda: all(v.position_ned[0] - a > 0.2 for v, a in zip(
            vehicles, held, strict=True)), 10.0), "the pass did not start"
        y0 = [v.position_ned[0] for v in vehicles]
        spin_until(lambda: False, 2.0)
        assert in_formation()
        flown = [v.position_ned[0] - a for v, a in zip(vehicles, y0, strict=True)]
        assert all(2.0 < f < 6.0 for f in flown), flown  # along the track at ~2 m/s
        for k, v in enumerate(vehicles):
            assert poses[k], f"no /uav{k}/mavlink/pose"
            last = poses[k][-1]
            assert last.header.frame_id == "insar_track"
            p = last.pose.position
            n, e, d = v.position_ned
            assert math.dist((p.x, p.y, p.z), (e, n, -d)) < 1.0
        ours = [s for m in diags for s in m.status if s.name.startswith("mavlink_bridge")]
        assert {s.name for s in ours} == {f"mavlink_bridge: uav{k}" for k in range(3)}
        last = {s.name: s for s in ours}
        assert all(s.message.startswith("linked") for s in last.values())
    finally:
        bridge_out = finish(bridge)
        finish(planner)
        for v in vehicles:
            v.stop()
    assert "pass start from the planner" in bridge_out, bridge_out


def test_a_dead_mavlink_thread_turns_the_bridge_error_and_exits_1(watcher):
    """FAULT INJECTION (test/fault_injection.py): the bridge's links start raising 4 s after
    its claim window (ros/claims.py: no I/O before it), which kills its I/O thread the way a
    bug would. The node must then report every UAV ERROR, never "linked" again, and exit with
    code 1 instead of living on as a zombie."""
    vehicle = SimVehicle(2, "udpin:127.0.0.1:0", "ardupilot", start_ned=(0.0, 0.0, -10.0),
                         max_speed=20.0, max_accel=10.0, airborne=True)
    vehicle.start()
    fault = os.path.join(os.path.dirname(__file__), "fault_injection.py")
    cmd = [PY, fault, str(4.0 + DISCOVERY_WINDOW_S), "uav_insar_planner.ros.mavlink_bridge",
           "--ros-args",
           "-p", f"connections:=['udpout:127.0.0.1:{vehicle.port}']", "-p", "target_sysids:=[2]"]
    bridge = subprocess.Popen(cmd, env=ros_env(), stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        def bridge_says(level):
            return [s for m in watcher.diagnostics for s in m.status
                    if s.name == "mavlink_bridge: uav0" and s.level == level]

        assert watcher.spin_until(lambda: bridge_says(DiagnosticStatus.OK), 20.0), "never linked"
        assert watcher.spin_until(lambda: bridge_says(DiagnosticStatus.ERROR), 10.0), \
            "the bridge kept reporting OK with its I/O thread dead"
        assert "thread died" in bridge_says(DiagnosticStatus.ERROR)[-1].message
        assert bridge.wait(timeout=10) == 1
        watcher.spin_until(lambda: False, 0.5)
        levels = [s.level for m in watcher.diagnostics for s in m.status
                  if s.name == "mavlink_bridge: uav0"]
        after = levels[levels.index(DiagnosticStatus.ERROR):]
        assert set(after) == {DiagnosticStatus.ERROR}  # nothing said OK after the death
    finally:
        out = finish(bridge)
        vehicle.stop()
    assert "MAVLink I/O thread died: RuntimeError: fault injection" in out, out


def test_a_formation_beyond_float32_is_dropped_at_entry(watcher):
    """A formation x of 1e39 is finite but does not fit MAVLink's float32 (packing it raised
    inside the I/O thread once): the bridge validates at entry, so it is dropped with one log
    line, counted on /diagnostics, the link stays OK and the previous formation is flown.
    The test node publishes one plan (formation + power of one identity, ros/plan_msgs.py)."""
    from geometry_msgs.msg import Pose, PoseArray
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension

    from uav_insar_planner.ros.plan_msgs import PlanId
    from uav_insar_planner.ros.topics import LATCHED

    vehicle = SimVehicle(2, "udpin:127.0.0.1:0", "ardupilot", start_ned=(0.0, 0.0, -10.0),
                         max_speed=20.0, max_accel=10.0, airborne=True)
    vehicle.start()
    bridge = start("uav_insar_planner.ros.mavlink_bridge", ros_env(),
                   f"connections:=['udpout:127.0.0.1:{vehicle.port}']", "target_sysids:=[2]")
    pub = watcher.node.create_publisher(PoseArray, "/formation", LATCHED)
    try:
        def bridge_says():
            return [s for m in watcher.diagnostics for s in m.status
                    if s.name == "mavlink_bridge: uav0"]

        def value(status, key):
            return next(v.value for v in status.values if v.key == key)

        def target_xz():  # y moves along the track
            x, _, z = value(bridge_says()[-1], "target_track_m").split() or (None,) * 3
            return x, z

        assert watcher.spin_until(lambda: any(s.level == DiagnosticStatus.OK
                                              for s in bridge_says()), 20.0), "never linked"
        # the smallest swarm, two UAVs; the bridge flies uav0, its one vehicle
        good = PoseArray(poses=[Pose(), Pose()])
        good.header.stamp.sec = 7
        good.poses[0].position.x, good.poses[0].position.z = 3.0, 12.0
        good.poses[1].position.x, good.poses[1].position.z = 6.0, 12.0
        power = Float64MultiArray(data=[0.1, 0.1])
        power.layout.dim = [MultiArrayDimension(label="uav", size=2, stride=2),
                            MultiArrayDimension(label="slot", size=1, stride=1),
                            MultiArrayDimension(label=PlanId(7, 0, "/watcher").label, size=1,
                                                stride=1)]
        pub.publish(good)
        watcher.node.create_publisher(Float64MultiArray, "/formation/power",
                                      LATCHED).publish(power)
        assert watcher.spin_until(lambda: target_xz() == ("3.000", "12.000"), 10.0)
        poison = PoseArray(poses=[Pose(), Pose()])  # stamp 0: a plan of its own if valid
        poison.poses[0].position.x, poison.poses[0].position.z = 1e39, 10.0
        poison.poses[1].position.x, poison.poses[1].position.z = 6.0, 12.0
        pub.publish(poison)
        assert watcher.spin_until(
            lambda: value(bridge_says()[-1], "bad_plan_messages") == "1", 10.0), \
            "the bad formation was not counted"
        watcher.spin_until(lambda: False, 1.5)  # the I/O thread would have died by now
        last = bridge_says()[-1]
        assert last.level == DiagnosticStatus.OK and last.message.startswith("linked"), \
            last.message
        assert target_xz() == ("3.000", "12.000")
        assert value(last, "bad_plan_messages") == "1"
    finally:
        out = finish(bridge)
        vehicle.stop()
    dropped = [line for line in out.splitlines() if "dropped plan message" in line]
    assert len(dropped) == 1 and "poses[0].position.x: value 1e+39" in dropped[0], out
    assert "thread died" not in out, out
