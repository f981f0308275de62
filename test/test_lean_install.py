"""A UAV's computer installs the package without the planner's libraries (issue 26, part 5):
`install_requires` is what `agent` and `mavlink_bridge` import, the `uav` extra adds the ROS
wheels, and the solver, plotting and bag libraries are the `planner` extra (setup.py).

Built here as a user builds it: a fresh venv, `pip install '<this tree>[uav]'` (from a copy of
the tree, so nothing is built inside it). From that venv, one UAV's stack (a bridge and an
agent on its autopilot, in /uav1) flies a plan of the planner of this Python, on a private ROS
domain, and stops cleanly on Ctrl-C. Skipped with the reason when the package registry cannot
be reached. Ports 31000-31099 (this file's own).
"""
from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import process_group
import pytest
from conftest import REPO
from venvs import new_venv, pip_install, tree_copy

from uav_insar_planner.demo.processes import executable, start_process
from uav_insar_planner.extras import INSTALL_PLANNER, PLANNER_MODULES, SOLVER_MODULES
from uav_insar_planner.param_specs.nodes import FIRST_SYSID
from uav_insar_planner.params import params_from_mapping
from uav_insar_planner.published import formation_points
from uav_insar_planner.solver import solve

pytestmark = pytest.mark.timeout(240)
VEHICLE_PORT = 31010
K = 1  # the UAV whose computer this is
NODE_MODULES = ("uav_insar_sim.agent_node", "uav_insar_planner.ros.mavlink_bridge")
PIP_TIMEOUT_S = 180


def test_the_uav_nodes_import_no_planner_library():
    """In this (full) install, importing the two nodes loads none of the planner's libraries:
    the guard against an eager import creeping back, on every run."""
    code = (f"import sys\nfor m in {NODE_MODULES!r}: __import__(m)\n"
            f"print(sorted(m for m in {PLANNER_MODULES!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60, cwd=REPO, check=True).stdout
    assert out.strip() == "[]", out


def _setup_list(name: str) -> list[str]:
    """The literal list assigned to `name` at the top of setup.py."""
    tree = ast.parse((REPO / "setup.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and [t.id for t in node.targets] == [name]:
            return ast.literal_eval(node.value)
    raise AssertionError(f"setup.py assigns no {name}")


def test_the_planner_extra_is_what_the_missing_line_names():
    """setup.py's PLANNER and extras.py's PLANNER_MODULES name the same libraries (each
    distribution here is imported under its own name)."""
    names = [req.split(">")[0].split("=")[0].split("[")[0] for req in _setup_list("PLANNER")]
    assert sorted(names) == sorted(PLANNER_MODULES)


@pytest.fixture(scope="module")
def lean(tmp_path_factory) -> Path:
    """The bin/ folder of a fresh venv with `pip install '<tree>[uav]'`."""
    root = tmp_path_factory.mktemp("lean")
    src = tree_copy(root / "src")
    bin_dir = new_venv(root / "venv")
    pip_install(bin_dir, [f"{src}[uav]"], PIP_TIMEOUT_S)
    return bin_dir


def test_the_lean_venv_has_the_nodes_and_none_of_the_planner_libraries(lean: Path):
    code = ("import importlib.util as u\n"
            f"print([m for m in {PLANNER_MODULES!r} if u.find_spec(m)])\n"
            "print([m for m in ('rclpy', 'pymavlink', 'serial', 'numpy', 'yaml') "
            "if not u.find_spec(m)])")
    out = process_group.run([str(lean / "python"), "-c", code], capture_output=True, text=True,
                            timeout=60, check=True).stdout
    assert out.splitlines() == ["[]", "[]"], out  # none of the planner's, all of the nodes'
    assert all((lean / name).exists() for name in ("agent", "mavlink_bridge"))


def test_the_lean_venv_names_the_extra_for_the_planner_and_the_tools(lean: Path,
                                                                     ros_domain: int):
    for cmd, prefix, modules in (
            ([str(lean / "uav-insar"), "solve"], "uav-insar solve: error: needs ",
             PLANNER_MODULES),
            ([str(lean / "planner"), "--ros-args"], "[ERROR] [planner]: needs ", SOLVER_MODULES)):
        done = process_group.run(cmd, capture_output=True, text=True, timeout=60)
        assert done.returncode == 1 and done.stdout == "", (done.stdout, done.stderr)
        assert done.stderr == (f"{prefix}{', '.join(modules)}, which this install leaves out "
                               "(a UAV's lean install has only what agent and mavlink_bridge "
                               f"need); {INSTALL_PLANNER}\n")


def test_a_uav_stack_from_the_lean_venv_flies_the_planners_plan(lean: Path, watcher):
    """The bridge (uav_id 1) and the agent (position_source autopilot) of the lean venv, in
    /uav1, beside a vehicle simulator and the planner of this Python: the bridge reads its
    autopilot, the agent republishes those poses and flies the plan; Ctrl-C stops both, 0."""
    x, y, z = formation_points(solve(params_from_mapping({})))[K]
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("PYTHONPATH", None)  # the lean processes import the installed copy, nothing else
    ns = ["--ros-args", "-r", f"__ns:=/uav{K}", "-p", f"uav_id:={K}"]
    vehicle = start_process([*executable("uav-insar-vehicle"), "--sysid", str(FIRST_SYSID + K),
                             "--listen", f"udpin:127.0.0.1:{VEHICLE_PORT}", "--airborne",
                             "--start-ned", str(y - 3.0), str(x), str(-z)], env)
    bridge = start_process([str(lean / "mavlink_bridge"), *ns, "-p",
                            f"connections:=['udpout:127.0.0.1:{VEHICLE_PORT}']", "-p",
                            f"target_sysids:=[{FIRST_SYSID + K}]"], env)
    agent = start_process([str(lean / "agent"), *ns, "-p", "position_source:=autopilot"], env)
    planner = start_process([*executable("planner"), "--ros-args"], env)
    everyone = [vehicle, bridge, agent, planner]
    try:
        up = watcher.spin_until(lambda: watcher.flown_plans[K] and len(watcher.poses[K]) >= 10,
                                60.0, everyone)
        names = set(watcher.node.get_node_names_and_namespaces())
        republished = {(p.header.stamp.sec, p.header.stamp.nanosec) for p in watcher.poses[K]}
        read = {(p.header.stamp.sec, p.header.stamp.nanosec) for p in watcher.mavlink_poses[K]}
        for proc in (bridge, agent):
            process_group.interrupt_group(proc)
        codes = [bridge.returncode, agent.returncode]
    finally:
        for proc in everyone:
            process_group.interrupt_group(proc)
    bridge_out, agent_out = bridge.stdout.read(), agent.stdout.read()
    assert up, (bridge_out[-2000:], agent_out[-2000:])
    assert {("mavlink_bridge", f"/uav{K}"), ("agent", f"/uav{K}")} <= names, names
    # the agent's poses are its autopilot's, stamp and all (the watcher may have matched the
    # agent's topic before the bridge's, so not every one of them was seen at both)
    assert len(republished & read) >= 5, (len(republished), len(read))
    assert codes == [0, 0], (codes, bridge_out[-2000:], agent_out[-2000:])
    assert "formation received" in bridge_out, bridge_out
    assert f"uav{K}: flying " in agent_out, agent_out
    for out in (bridge_out, agent_out):
        assert "Traceback" not in out and "[ERROR]" not in out, out
