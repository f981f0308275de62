"""The launch files (launch/, uav_insar_planner/ros/launch_files.py) under the real ROS 2 command
line of ../shared/wheels/ros2-jazzy (issue 41, item 4): `ros2 launch`, `ros2 topic echo`,
`ros2 param set` and `ros2 service call`, installed beside the package in a venv made for them
once per session, on both paths a user has:

- pip: `pip install '<tree>[ros]'` (the wheel: the launch files, the params file and the ament
  index marker in the venv's share/, the executables in its bin/), the command line's own
  requirements and the shared wheels (`--no-deps`, as their README says);
- colcon: the same tree installed into a prefix of its own as colcon's ament_python build
  does (`setup.py install --prefix`, the executables in lib/uav_insar_planner by setup.cfg),
  first on AMENT_PREFIX_PATH and PYTHONPATH as colcon's setup.bash puts it.

Every test is on a private ROS domain, and its `ros2 launch` is stopped with SIGINT, as Ctrl-C
does; its process group must be empty then. Skipped, with the reason, where the wheels are
absent or the package registry unreachable. Ports 34100-34199.
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

import process_group
import pytest
import yaml
from conftest import REPO
from venvs import new_venv, pip_install, tree_copy

from uav_insar_planner.extras import PLANNER_MODULES
from uav_insar_planner.param_specs.nodes import FIRST_SYSID
from uav_insar_planner.params import params_from_mapping
from uav_insar_planner.published import formation_points
from uav_insar_planner.ros.launch_files import LAUNCH_FILES, PACKAGE
from uav_insar_planner.solver import solve

pytestmark = pytest.mark.timeout(600)  # the first test builds the venv (about a minute)
WHEELS = REPO.parent / "shared" / "wheels" / "ros2-jazzy"
# What the command line and launch import beyond rclpy (the wheels' README).
CLI_REQUIREMENTS = ("psutil", "packaging", "argcomplete", "catkin_pkg", "empy", "pyyaml",
                    "osrf-pycommon")
PIP_TIMEOUT_S = 420
# Without the daemon, which would outlive the test in a session of its own; the tools then
# discover the graph themselves, and 0.5 s is often too short for that here.
DIRECT = ("--no-daemon", "--spin-time", "3")
# What this Python's ROS wheels put in the environment of its children (LD_LIBRARY_PATH of the
# suite's venv, the bootstrap's guard): the new venv's processes find their own.
NOT_INHERITED = ("PYTHONPATH", "LD_LIBRARY_PATH", "_ROS_WHEELS_BOOTSTRAP_COMPLETE",
                 "AMENT_PREFIX_PATH", "VIRTUAL_ENV", "ROS_STATIC_PEERS")
SWARM_BASE_PORT = 34100  # swarm.launch.py's vehicles: 34100, 34110
UAV_PORT = 34150  # the vehicle of uav.launch.py's UAV
STOP_S = 30.0  # launch: SIGINT, SIGTERM 5 s later, SIGKILL 5 s after that
STARTED = re.compile(r"\[INFO\] \[([\w-]+)\]: process started with pid \[(\d+)\]")


@dataclass(frozen=True)
class Ros2:
    """The venv with the package and the ROS 2 command line, the colcon-like prefix, and the
    folder of launch's and the nodes' log files (not ~/.ros/log)."""
    bin: Path
    colcon: Path
    logs: Path

    def env(self, domain: int, colcon: bool = False) -> dict[str, str]:
        env = {k: v for k, v in os.environ.items() if k not in NOT_INHERITED}
        prefixes = [self.colcon, self.bin.parent] if colcon else [self.bin.parent]
        env.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                   AMENT_PREFIX_PATH=os.pathsep.join(map(str, prefixes)), PYTHONUNBUFFERED="1",
                   ROS_LOG_DIR=str(self.logs))
        if colcon:
            env["PYTHONPATH"] = str(self.colcon / "lib" / f"python{sys.version_info.major}."
                                    f"{sys.version_info.minor}" / "site-packages")
        return env


@pytest.fixture(scope="session")
def ros2(tmp_path_factory: pytest.TempPathFactory) -> Ros2:
    wheels = sorted(WHEELS.glob("*.whl"))
    if not wheels:
        pytest.skip(f"no ROS 2 command line and launch wheels in {WHEELS} (see issue 41)")
    root = tmp_path_factory.mktemp("ros2")
    src = tree_copy(root / "src")
    bin_dir = new_venv(root / "venv")
    pip_install(bin_dir, [f"{src}[ros]", *CLI_REQUIREMENTS], PIP_TIMEOUT_S)
    pip_install(bin_dir, ["--no-deps", *map(str, wheels)], 120)
    build = root / "build"
    build.mkdir()
    done = process_group.run(
        [str(bin_dir / "python"), "setup.py", "-q", "egg_info", "--egg-base", str(build),
         "build", "--build-base", str(build / "build"), "install", "--prefix",
         str(root / "colcon"), "--record", str(build / "install.log"),
         "--single-version-externally-managed"],
        cwd=src, capture_output=True, text=True, timeout=180)
    assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
    return Ros2(bin_dir, root / "colcon", root / "log")


class Launched:
    """`ros2 launch ARGS` in a session of its own, its output collected line by line."""

    def __init__(self, ros2: Ros2, env: dict[str, str], *args: str) -> None:
        self.proc = subprocess.Popen([str(ros2.bin / "ros2"), "launch", *args], env=env,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True, start_new_session=True)
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    @property
    def text(self) -> str:
        return "\n".join(self.lines)

    def started(self) -> dict[str, int]:
        """The processes launch started: label -> pid."""
        return {m[1]: int(m[2]) for line in list(self.lines) if (m := STARTED.search(line))}

    def ctrl_c(self, group: bool) -> int | None:
        """SIGINT to the whole group (a terminal's Ctrl-C) or to `ros2 launch` alone; its exit
        code, None when it still ran STOP_S later."""
        if group:
            os.killpg(self.proc.pid, signal.SIGINT)
        else:
            self.proc.send_signal(signal.SIGINT)
        try:
            code = self.proc.wait(STOP_S)
        except subprocess.TimeoutExpired:
            return None
        self._reader.join(10)
        return code

    def left(self) -> list[str]:
        """The command lines of what is still in the launch's process group."""
        found = []
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
                if int(fields[2]) == self.proc.pid:  # pgrp
                    found.append((stat.parent / "cmdline").read_bytes().replace(b"\0", b" ")
                                 .decode(errors="replace"))
            except (OSError, IndexError, ValueError):
                continue  # ended while read
        return found

    def close(self) -> None:
        process_group.kill_group(self.proc)


def cli(ros2: Ros2, env: dict[str, str], watcher, *args: str,
        timeout: float = 30.0) -> tuple[int | None, str]:
    """`ros2 ARGS` run to its end while `watcher` spins (so it records what it brings about);
    its exit code (None: timed out) and output."""
    proc = subprocess.Popen([str(ros2.bin / "ros2"), *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        watcher.spin_until(lambda: proc.poll() is not None, timeout)
        code = proc.poll()
    finally:
        process_group.interrupt_group(proc)
    return code, proc.stdout.read()


def assert_stopped_cleanly(launched: Launched, code: int | None, labels: set[str]) -> None:
    out = launched.text
    assert code == 0, (code, out[-4000:])
    assert not launched.left(), launched.left()
    started = launched.started()
    assert labels <= set(started), (started, out[-4000:])
    for label, pid in started.items():
        own = [line for line in launched.lines if f"[{label}]" in line]
        assert f"[{label}]: process has finished cleanly [pid {pid}]" in out, \
            [line.split(", cmd ")[0] for line in own[-8:]]
    assert "Traceback" not in out and "process has died" not in out, out[-4000:]


def test_the_demo_and_the_launch_table_need_no_launch_and_no_planner_library():
    """`make demo` stays launch-free, and the launch files' logic (their table, the params
    file's reading) loads launch only to build and none of the planner's libraries, so that
    uav.launch.py runs on a UAV's lean install. Needs no wheels."""
    code = ("import sys\nimport uav_insar_planner.demo.mission, uav_insar_planner.demo.steps\n"
            "from uav_insar_planner.ros import launch_files as f\n"
            "f._scenario({'params_file': '', 'num_uavs': '4'}, f.Path('.'))\n"
            f"print(sorted(m for m in ('launch', 'launch_ros', *{PLANNER_MODULES!r}) "
            "if m in sys.modules))")
    done = process_group.run([sys.executable, "-c", code], capture_output=True, text=True,
                             timeout=60, cwd=REPO, check=True)
    assert done.stdout.strip() == "[]", done.stdout + done.stderr


def test_each_launch_file_declares_the_documented_arguments_and_refuses_bad_values(
        ros2: Ros2, ros_domain: int):
    """`--show-args` lists LAUNCH_FILES' arguments (the reference page's source); a value out
    of range ends `ros2 launch` with one line naming the argument, before any process."""
    env = ros2.env(ros_domain)
    for name, spec in LAUNCH_FILES.items():
        done = process_group.run([str(ros2.bin / "ros2"), "launch", "--show-args", PACKAGE,
                                  name], env=env, capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stdout + done.stderr
        shown = re.findall(r"^    '(\w+)':\n        .*(?:\n        \(default: '(.*)'\))?$",
                           done.stdout, re.MULTILINE)
        assert shown == [(a.name, a.default or "") for a in spec.args], done.stdout
    for args, words in ((["swarm.launch.py", "num_uavs:=11"], "num_uavs: value '11' is not "
                         "allowed; expected a whole number 2..10"),
                        (["uav.launch.py", "uav_id:=3"], "uav_id: value '3' is not allowed; "
                         "expected a whole number 0..2"),
                        (["uav.launch.py"], "uav_id")):
        done = process_group.run([str(ros2.bin / "ros2"), "launch", PACKAGE, *args], env=env,
                                 capture_output=True, text=True, timeout=60)
        out = done.stdout + done.stderr
        assert done.returncode != 0 and words in out, out
        assert "process started" not in out, out


def test_the_swarm_launch_flies_and_answers_the_ros2_tools(ros2: Ros2, ros_domain: int,
                                                           watcher):
    """swarm.launch.py with two UAVs and their simulated vehicles (pip path): the planner, two
    agents, the bridge and the vehicles come up; `ros2 topic echo /formation --once` prints
    the plan the watcher got; `ros2 param set /planner h_amb_min_m 0.9` brings a new one, and
    so does `ros2 service call /planner/replan`; Ctrl-C in the terminal stops them all."""
    env = ros2.env(ros_domain)
    launched = Launched(ros2, env, PACKAGE, "swarm.launch.py", "num_uavs:=2", "vehicles:=true",
                        f"base_port:={SWARM_BASE_PORT}")
    nodes = {("planner", "/"), ("agent0", "/"), ("agent1", "/"), ("mavlink_bridge", "/")}
    try:
        up = watcher.spin_until(lambda: nodes <= set(
            watcher.node.get_node_names_and_namespaces()) and watcher.formations, 60.0,
            [launched.proc])
        assert up, launched.text[-4000:]
        assert "agent2" not in str(watcher.node.get_node_names_and_namespaces())
        code, out = cli(ros2, env, watcher, "topic", "echo", *DIRECT, "/formation", "--once")
        assert code == 0, out
        echoed = yaml.safe_load(out.split("---")[0])
        plan = watcher.formations[-1]
        assert len(echoed["poses"]) == len(plan.poses) == 2, out
        for pose, got in zip(echoed["poses"], plan.poses, strict=True):
            assert pose["position"]["x"] == pytest.approx(got.position.x), out
            assert pose["position"]["z"] == pytest.approx(got.position.z), out

        def across() -> list[float]:
            return [p.position.x for p in watcher.formations[-1].poses]

        def stamp() -> tuple[int, int]:  # a plan's identity (a new plan, a new stamp)
            latest = watcher.formations[-1].header.stamp
            return latest.sec, latest.nanosec

        first = across()
        code, out = cli(ros2, env, watcher, "param", "set", *DIRECT, "/planner", "h_amb_min_m",
                        "0.9")
        assert code == 0 and "Set parameter successful" in out, out
        assert watcher.spin_until(lambda: across() != first, 20.0), (first, across())

        before = stamp()
        code, out = cli(ros2, env, watcher, "service", "call", "/planner/replan",
                        "std_srvs/srv/Trigger", timeout=40.0)
        assert code == 0 and "success=True" in out, out
        assert watcher.spin_until(lambda: stamp() != before, 20.0), (before, stamp())
        # the bridge reads both vehicles, at base_port and base_port + 10
        assert watcher.spin_until(lambda: all(watcher.mavlink_poses[k] for k in (0, 1)), 20.0,
                                  [launched.proc]), launched.text[-3000:]
        code = launched.ctrl_c(group=True)
    finally:
        launched.close()
    assert_stopped_cleanly(launched, code, {"planner-1", "agent-2", "agent-3",
                                            "mavlink_bridge-4", "vehicle2-5", "vehicle3-6"})


def test_a_uav_computer_and_the_ground_station_by_their_launch_files(
        ros2: Ros2, ros_domain: int, watcher, tmp_path: Path):
    """uav.launch.py uav_id:=1 on the colcon path (its executables from the prefix's
    lib/uav_insar_planner) beside a vehicle, and ground.launch.py on the pip path: the bridge
    and the agent in /uav1 fly the planner's plan on that vehicle's poses, the recorder takes
    them; Ctrl-C to each `ros2 launch` alone stops its processes, the bag closed."""
    k, sysid = 1, FIRST_SYSID + 7
    x, y, z = formation_points(solve(params_from_mapping({})))[k]
    vehicle = subprocess.Popen(
        [str(ros2.bin / "uav-insar-vehicle"), "--sysid", str(sysid), "--listen",
         f"udpin:127.0.0.1:{UAV_PORT}", "--airborne", "--start-ned", str(y - 3.0), str(x),
         str(-z)], env=ros2.env(ros_domain), stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL, start_new_session=True)
    uav = Launched(ros2, ros2.env(ros_domain, colcon=True), PACKAGE, "uav.launch.py",
                   f"uav_id:={k}", f"connection:=udpout:127.0.0.1:{UAV_PORT}",
                   f"target_sysid:={sysid}")
    bag = tmp_path / "bag"
    ground = Launched(ros2, ros2.env(ros_domain), PACKAGE, "ground.launch.py", f"bag:={bag}")
    nodes = {("mavlink_bridge", f"/uav{k}"), ("agent", f"/uav{k}"), ("planner", "/"),
             ("uav_insar_recorder", "/")}
    try:
        up = watcher.spin_until(lambda: nodes <= set(watcher.node.get_node_names_and_namespaces())
                                and len(watcher.poses[k]) >= 10 and f"uav{k}: flying" in uav.text,
                                90.0, [uav.proc, ground.proc, vehicle])
        assert up, (uav.text[-3000:], ground.text[-3000:])
        commands = {label: (Path("/proc") / str(pid) / "cmdline").read_bytes().split(b"\0")
                    for label, pid in uav.started().items()}
        codes = uav.ctrl_c(group=False), ground.ctrl_c(group=False)
    finally:
        uav.close()
        ground.close()
        process_group.interrupt_group(vehicle)
    colcon = str(ros2.colcon / "lib" / PACKAGE).encode()
    assert {label: any(part.startswith(colcon) for part in cmd)
            for label, cmd in commands.items()} == {"mavlink_bridge-1": True, "agent-2": True}
    assert "formation received" in uav.text, uav.text[-3000:]
    assert_stopped_cleanly(uav, codes[0], {"mavlink_bridge-1", "agent-2"})
    assert_stopped_cleanly(ground, codes[1], {"planner-1", "recorder-2"})
    recorded = re.search(r"recorded (\d+) messages on (\d+) topics to (.+)$", ground.text,
                         re.MULTILINE)
    assert recorded and int(recorded[1]) > 10, ground.text[-3000:]
    assert (bag / "metadata.yaml").is_file()
