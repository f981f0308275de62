"""The launch files of launch/ (`swarm.launch.py`, `uav.launch.py`, `ground.launch.py`): what
each starts and the arguments it declares (LAUNCH_FILES, from which the documentation's launch
page is generated), and their LaunchDescriptions (`launch_description`), which the files only
call, so that the logic is here, checked and tested with the package.

launch and launch_ros are no PyPI packages (docs/ros/paths.md): they are imported only when a
description is built, so the table reads without them (the docs build, `make demo`).
Executables are found where the install put them, so one launch file serves every path: in
PREFIX/lib/uav_insar_planner of the ament index (colcon, setup.cfg), else beside the Python that
runs `ros2 launch` (pip's bin/), else on PATH. The params file's default is config/params.yaml
beside the launch file's folder: share/uav_insar_planner/ when installed, the source tree when
a file is launched by its path.
"""
from __future__ import annotations

import shutil
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uav_insar_planner.autopilots.profiles import AUTOPILOTS
from uav_insar_planner.param_specs.nodes import (
    FIRST_PORT,
    FIRST_SYSID,
    PORT_STEP,
    spec_named,
    vehicle_start_ned,
)
from uav_insar_planner.param_specs.science import SPEC_BY_NAME
from uav_insar_planner.swarm import (
    DEFAULT_NUM_UAVS,
    MAX_UAVS,
    MIN_UAVS,
    agent_name,
    fit_to_swarm,
    uav_name,
    uavs,
)

if TYPE_CHECKING:
    from launch import LaunchContext, LaunchDescription
    from launch.action import Action

PACKAGE = "uav_insar_planner"
PARAMS_FILE = Path("config") / "params.yaml"  # beside launch/, in share/PACKAGE and the tree
BOOLEANS = ("true", "false")
MAX_PORT = 65535
# Python nodes write their stdout in blocks when it is no terminal: launch then shows a node's
# lines late, or never when it is killed.
UNBUFFERED = {"PYTHONUNBUFFERED": "1"}


@dataclass(frozen=True)
class LaunchArg:
    """One argument of a launch file (a DeclareLaunchArgument), as the reference lists it."""
    name: str
    default: str | None  # None: required
    description: str
    choices: tuple[str, ...] = ()


PARAMS_FILE_ARG = LaunchArg(
    "params_file", "", "the params file every node starts with; empty: the package's "
    "`config/params.yaml` (Table I)")
NUM_UAVS_ARG = LaunchArg(
    "num_uavs", "", f"the swarm's size, {MIN_UAVS} to {MAX_UAVS}, for the planner and agents it "
    "starts, R_min,k fitted to it as the demo's `--uavs` fits it; empty: the params file's "
    f"({DEFAULT_NUM_UAVS} in Table I)")
AUTOPILOT_ARG = LaunchArg(
    "autopilot", spec_named("autopilot", "mavlink_bridge").default,
    "the bridge's mode numbers and arming sequence", AUTOPILOTS)
VEHICLES_ARG = LaunchArg(
    "vehicles", "false", "true: one simulated vehicle (`uav-insar-vehicle`, of `autopilot`) per "
    "UAV, started airborne where the bridge sends", BOOLEANS)
BASE_PORT_ARG = LaunchArg(
    "base_port", str(FIRST_PORT), f"UAV k's vehicle is at UDP 127.0.0.1:base_port + {PORT_STEP} "
    "k: the bridge sends there, a simulated vehicle listens there")
UAV_ID_ARG = LaunchArg(
    "uav_id", None, "the UAV this computer flies, 0 (the master) to num_uavs - 1; its nodes "
    "run in the namespace /uavK")
CONNECTION_ARG = LaunchArg(
    "connection", "", "the bridge's pymavlink connection to this UAV's autopilot "
    "(udpout:HOST:PORT, udpin:HOST:PORT, tcp:HOST:PORT, /dev/ttyUSB0,57600); empty: "
    f"udpout:127.0.0.1:{FIRST_PORT} + {PORT_STEP} K")
TARGET_SYSID_ARG = LaunchArg(
    "target_sysid", "", f"the MAVLink system id of this UAV's autopilot, 1..255; empty: "
    f"{FIRST_SYSID} + K")
BAG_ARG = LaunchArg(
    "bag", "", "the bag folder `uav-insar record` creates (it must not exist); empty: "
    "bags/ground_<UTC time> in the current folder")


@dataclass(frozen=True)
class LaunchFile:
    """A launch file of launch/: what it starts, its arguments, and the builder of its actions
    from the arguments' values and the folder holding launch/ and config/."""
    starts: str
    args: tuple[LaunchArg, ...]
    build: Callable[[dict[str, str], Path], list[Action]]


class LaunchError(RuntimeError):
    """A launch argument's value refused, one line each; launch prints it and exits 1."""


def _executable(name: str) -> str:
    """The path of the suite's executable `name` (module docstring: colcon's, pip's, PATH's)."""
    try:
        from ament_index_python.packages import get_package_prefix

        colcon = Path(get_package_prefix(PACKAGE)) / "lib" / PACKAGE / name
    except (ImportError, LookupError, ValueError):  # no index, or not in it: not colcon's
        colcon = None
    beside = Path(sys.executable).parent / name
    for found in (colcon, beside, shutil.which(name)):
        if found is not None and Path(found).is_file():
            return str(found)
    raise LaunchError(f"{name}: not found in lib/{PACKAGE} of the ament index, beside "
                      f"{sys.executable} or on PATH; install {PACKAGE} (docs/ros/paths.md)")


def _node(executable: str, path: Path, own: dict[str, Any], **kw: Any) -> Action:
    """Node `executable` with the params file `path`, then its `own` values (a params file
    launch_ros writes, later so winning), none when empty. No object may stand twice in `own`:
    yaml.dump would write an alias, which the suite's params-file reader refuses."""
    from launch_ros.actions import Node

    return Node(executable=_executable(executable), parameters=[str(path)] + ([own] if own else []),
                output="screen", additional_env=UNBUFFERED, **kw)


def _process(executable: str, args: list[str], name: str) -> Action:
    from launch.actions import ExecuteProcess

    return ExecuteProcess(cmd=[_executable(executable), *args], name=name, output="screen",
                          additional_env=UNBUFFERED)


def _number(arg: LaunchArg, text: str, low: int, high: int) -> int:
    value = int(text) if text.strip().lstrip("+-").isdigit() else None
    if value is None or not low <= value <= high:
        raise LaunchError(f"{arg.name}: value {text[:40]!r} is not allowed; expected a whole "
                          f"number {low}..{high}")
    return value


def _scenario(values: dict[str, str], root: Path) -> tuple[Path, int, dict[str, Any]]:
    """The params file, the swarm's size and the scenario overrides for the planner and the
    agents: num_uavs and R_min,k fitted to it, as the demo's --uavs (none when not given)."""
    from uav_insar_planner.params import ParamError
    from uav_insar_planner.params_file import read_params_file

    path = Path(values["params_file"] or root / PARAMS_FILE).expanduser().resolve()
    try:
        file = read_params_file(path)  # the nodes' own verdict, before any of them starts
    except ParamError as exc:
        raise LaunchError("\n".join(exc.problems)) from None
    if not values["num_uavs"]:
        return path, int(file.get("num_uavs", DEFAULT_NUM_UAVS)), {}
    n = _number(NUM_UAVS_ARG, values["num_uavs"], MIN_UAVS, MAX_UAVS)
    rates = file.get("rate_min_mbps", SPEC_BY_NAME["rate_min_mbps"].default)
    return path, n, {"num_uavs": n, "rate_min_mbps": [float(r) for r in fit_to_swarm(rates, n)]}


def _swarm(values: dict[str, str], root: Path) -> list[Action]:
    """The planner, agent0..agentN-1 (on their autopilots' poses), the all-in-one bridge to
    the N vehicles at base_port + PORT_STEP k and, with vehicles:=true, those vehicles."""
    path, n, scenario = _scenario(values, root)
    base = _number(BASE_PORT_ARG, values["base_port"], 1, MAX_PORT - PORT_STEP * (n - 1))
    ports = [base + PORT_STEP * k for k in uavs(n)]
    autopilot = values["autopilot"]
    actions = [_node("planner", path, scenario)]
    actions += [_node("agent", path, {**scenario, "uav_id": k, "position_source": "autopilot"},
                      name=agent_name(k))
                for k in uavs(n)]
    actions.append(_node("mavlink_bridge", path, {
        "autopilot": autopilot, "connections": [f"udpout:127.0.0.1:{p}" for p in ports],
        "target_sysids": [FIRST_SYSID + k for k in uavs(n)]}))
    if values["vehicles"] == "true":
        actions += [_process("uav-insar-vehicle", [
            "--sysid", str(FIRST_SYSID + k), "--listen", f"udpin:127.0.0.1:{ports[k]}",
            "--autopilot", autopilot, "--airborne", "--start-ned",
            *(str(v) for v in vehicle_start_ned(k))], f"vehicle{FIRST_SYSID + k}")
            for k in uavs(n)]
    return actions


def _uav(values: dict[str, str], root: Path) -> list[Action]:
    """UAV K's bridge (its autopilot only) and agent (on that autopilot's poses) in /uavK."""
    path, n, scenario = _scenario(values, root)
    k = _number(UAV_ID_ARG, values["uav_id"], 0, n - 1)
    bridge: dict[str, Any] = {"uav_id": k, "autopilot": values["autopilot"]}
    if values["connection"]:  # else the bridge's own default for UAV K
        bridge["connections"] = [values["connection"]]
    if values["target_sysid"]:
        bridge["target_sysids"] = [_number(TARGET_SYSID_ARG, values["target_sysid"], 1, 255)]
    namespace = "/" + uav_name(k)
    return [_node("mavlink_bridge", path, bridge, namespace=namespace),
            _node("agent", path, {**scenario, "uav_id": k, "position_source": "autopilot"},
                  namespace=namespace)]


def _ground(values: dict[str, str], root: Path) -> list[Action]:
    """The planner and `uav-insar record BAG`, which Ctrl-C closes with the bag complete."""
    path, _, scenario = _scenario(values, root)
    stamp = time.strftime("%Y_%m_%d-%H_%M_%S", time.gmtime())
    bag = Path(values["bag"] or Path("bags") / f"ground_{stamp}").expanduser().absolute()
    if bag.exists():  # the recorder would refuse it after the planner started
        raise LaunchError(f"bag: {str(bag)[:200]!r} exists; expected a new folder (a bag is "
                          "never overwritten)")
    return [_node("planner", path, scenario),
            _process("uav-insar", ["record", str(bag)], "recorder")]


LAUNCH_FILES: dict[str, LaunchFile] = {
    "swarm.launch.py": LaunchFile(
        "the whole swarm on one machine: the `planner`, one `agent` per UAV (`agent0`.., on "
        "their autopilots' poses), the all-in-one `mavlink_bridge` and, with `vehicles:=true`, "
        "one simulated vehicle per UAV",
        (PARAMS_FILE_ARG, NUM_UAVS_ARG, AUTOPILOT_ARG, VEHICLES_ARG, BASE_PORT_ARG), _swarm),
    "uav.launch.py": LaunchFile(
        "one UAV's computer: its `mavlink_bridge` (that UAV's autopilot only) and its `agent` "
        "(on that autopilot's poses), both in the namespace /uavK",
        (UAV_ID_ARG, AUTOPILOT_ARG, CONNECTION_ARG, TARGET_SYSID_ARG, PARAMS_FILE_ARG,
         NUM_UAVS_ARG), _uav),
    "ground.launch.py": LaunchFile(
        "the ground station: the `planner` and the recorder (`uav-insar record`), whose bag "
        "Ctrl-C closes",
        (PARAMS_FILE_ARG, NUM_UAVS_ARG, BAG_ARG), _ground),
}


def _actions(context: LaunchContext, name: str, root: Path) -> list[Action]:
    spec = LAUNCH_FILES[name]
    return spec.build({a.name: context.launch_configurations[a.name] for a in spec.args}, root)


def launch_description(launch_file: str) -> LaunchDescription:
    """The description of `launch_file` (a file of launch/, its path): its arguments declared,
    its processes built once their values are known (N agents, N vehicles)."""
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument, OpaqueFunction

    path = Path(launch_file).resolve()
    declared = [DeclareLaunchArgument(
        a.name, description=a.description,
        **({} if a.default is None else {"default_value": a.default}),
        **({"choices": list(a.choices)} if a.choices else {}))
        for a in LAUNCH_FILES[path.name].args]
    return LaunchDescription([*declared, OpaqueFunction(
        function=_actions, args=[path.name, path.parent.parent])])
