"""Shared fixtures: a private ROS domain per test (real rclpy on Fast DDS), an rclpy Context
on it, and real child processes on it."""
from __future__ import annotations

import itertools
import os
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path
from types import SimpleNamespace

import pytest
from process_group import kill_group

REPO = Path(__file__).resolve().parent.parent
_counter = itertools.count()


def _next_domain() -> int:
    # Fast DDS takes domains 0..232; pid spreads parallel pytest runs, the counter separates
    # tests within one. 0 stays free for whatever else runs on the machine. Each worker of a
    # pytest-xdist run (`make test`) takes the domains of its own residue modulo the workers'
    # count, so that two of their tests never meet on one domain.
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    index, count, spread = ((int(worker[2:]), int(os.environ["PYTEST_XDIST_WORKER_COUNT"]),
                             os.getppid()) if worker.startswith("gw") else (0, 1, os.getpid()))
    return 1 + ((spread * 7 + next(_counter)) % (232 // count)) * count + index


@pytest.fixture
def ros_domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A domain id for this test alone, exported as ROS_DOMAIN_ID, discovery kept on this
    host (no multicast to the network)."""
    domain = _next_domain()
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    return domain


@pytest.fixture
def another_domain(ros_domain: int) -> int:
    """A second private domain, different from ros_domain."""
    domain = _next_domain()
    while domain == ros_domain:
        domain = _next_domain()
    return domain


class Children:
    """Starts Python child processes with the test's environment, each in a process group of
    its own; kills the groups at the end."""

    def __init__(self) -> None:
        self.procs: list[subprocess.Popen] = []

    def start(self, *args: str, script: Path | None = None,
              module: str | None = None) -> subprocess.Popen:
        env = dict(os.environ, PYTHONPATH=str(REPO), PYTHONUNBUFFERED="1")
        cmd = [sys.executable] + (["-m", module] if module else [str(script)])
        proc = subprocess.Popen(cmd + list(args), env=env, cwd=REPO, text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                start_new_session=True)
        self.procs.append(proc)
        return proc

    def run(self, *args: str, timeout: float = 20, **kw: object) -> subprocess.CompletedProcess:
        proc = self.start(*args, **kw)
        try:
            out, err = proc.communicate(timeout=timeout)
        finally:
            kill_group(proc)
        return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)

    def close(self) -> None:
        for proc in self.procs:
            kill_group(proc)
            proc.communicate(timeout=10)


@pytest.fixture
def children(ros_domain: int):
    kids = Children()
    yield kids
    kids.close()


@pytest.fixture
def vehicles():
    """make(autopilot, sysid): a simulated vehicle on a free UDP port, started, stopped after
    the test (test_start_missions.py, test_upload_mission.py)."""
    from uav_insar_sim.vehicle.simulator import SimVehicle

    made: list[SimVehicle] = []

    def make(autopilot: str, sysid: int) -> SimVehicle:
        vehicle = SimVehicle(sysid, "udpin:127.0.0.1:0", autopilot)
        vehicle.start()
        made.append(vehicle)
        return vehicle

    yield make
    for vehicle in made:
        vehicle.stop()


@pytest.fixture
def repo() -> Path:
    """The repository root (the child processes' working directory)."""
    return REPO


@pytest.fixture
def ros_context(ros_domain: int):
    """An initialized rclpy Context of its own on the test's domain."""
    import rclpy

    ctx = rclpy.Context()
    rclpy.init(args=["test"], context=ctx, domain_id=ros_domain)
    yield ctx
    ctx.try_shutdown()


@pytest.fixture
def procs(ros_domain: int):
    """`procs(name, *ros_args)` starts executable `name` (planner, agent, mavlink_bridge) with
    `--ros-args ros_args` on the test's domain, as `ros2 run` would; leftovers are killed."""
    from uav_insar_planner.demo.processes import start_node

    started: list[subprocess.Popen] = []

    def start(name: str, *ros_args: str) -> subprocess.Popen:
        started.append(start_node(name, ros_args, dict(os.environ)))
        return started[-1]

    yield start
    for proc in started:
        kill_group(proc)
        proc.communicate(timeout=10)


@pytest.fixture
def watcher(ros_context):
    """The suite's TopicWatcher (ros/tools/topic_watcher.py) in the test's context."""
    from uav_insar_planner.ros.tools.topic_watcher import TopicWatcher

    w = TopicWatcher(ros_context)
    yield w
    w.destroy()


@contextmanager
def private_graph(num_uavs: int = 3, domain: int | None = None):
    """A private domain of its own (`domain`, or the next free one) for processes started with
    `env` (discovery on this host, no static peers), and a TopicWatcher of `num_uavs` UAVs'
    topics on it; both shut down on leaving, so nothing of it stays on the graph for the tests
    that follow. Yields (env, watcher)."""
    import rclpy

    from uav_insar_planner.demo.processes import ros_env
    from uav_insar_planner.ros.tools.topic_watcher import TopicWatcher

    domain = _next_domain() if domain is None else domain
    env = dict(ros_env(domain), PYTHONPATH=str(REPO))
    env.pop("ROS_STATIC_PEERS", None)
    ctx = rclpy.Context()
    rclpy.init(args=["test"], context=ctx, domain_id=domain)
    w = TopicWatcher(ctx, num_uavs=num_uavs)
    try:
        yield env, w
    finally:
        w.destroy()
        ctx.try_shutdown()


MISSION_SLOTS = 4


@pytest.fixture(scope="session")
def mission(tmp_path_factory):
    """A real recorded mission, once per session (test_bag_record.py, test_foxglove_layout.py):
    three agent processes and the planner on a private domain, MISSION_SLOTS slots at
    time_scale 40, recorded by `uav-insar record`'s recorder process; `bag`, the recorder's
    exit `code` and last `line`, and what a watcher saw: the `formation`, the `rates`."""
    from visualization_msgs.msg import MarkerArray

    from uav_insar_planner.demo.processes import start_node, start_process, stop_nodes
    from uav_insar_planner.demo.recorder import recorder_ready, stop_recorder

    with private_graph() as (env, w):
        bag = tmp_path_factory.mktemp("bags") / "mission"
        recorder = start_process([sys.executable, "-m", "uav_insar_planner.cli", "record",
                                  str(bag)], env)
        nodes = [start_node("agent", ["-p", f"uav_id:={k}", "-p", "time_scale:=40.0", "-p",
                                      f"num_slots:={MISSION_SLOTS}", "-r", f"__node:=agent{k}"],
                            env)
                 for k in range(3)]
        try:
            assert w.spin_until(lambda: w.agents_matched() and recorder_ready(w.node, w.uavs), 30.0,
                                [*nodes, recorder]), "agents or recorder did not come up"
            nodes.append(start_node("planner", ["-p", f"num_slots:={MISSION_SLOTS}"], env))
            # the latched plan reaches the watcher whenever its discovery of the planner ends,
            # which may be after the agents flew their slots
            assert w.spin_until(lambda: w.formations and all(len(w.rates[k]) >= MISSION_SLOTS
                                                             for k in range(3)), 60.0,
                                nodes), "the mission did not complete"
            # the planner draws the agents' poses once its discovery of them ends (seconds on a
            # busy host): wait for its first flown markers, then a last second of them
            flown = []
            w.node.create_subscription(MarkerArray, "/formation/markers/flown", flown.append, 10)
            assert w.spin_until(lambda: flown, 30.0, nodes), "no flown markers from the planner"
            w.spin_until(lambda: False, 1.0)
            code, line = stop_recorder(recorder)
            seen = SimpleNamespace(bag=bag, code=code, line=line, formation=w.formations[0],
                                   rates={k: list(w.rates[k]) for k in range(3)})
        finally:
            stop_nodes(nodes + [recorder])
    yield seen


# `make test` runs the suite on two pytest-xdist workers (Makefile). These modules fly a swarm
# in real time and judge it by its timing (slot durations, spreads, speeds), some on fixed
# ports or with side-by-side flights (test/side_by_side.py): they form one work unit, run by one
# worker one after the other as in a serial run, while the other worker runs the rest. (Two of
# them at once made a field-starts run see slots of 0.03 s and a UAV stuck short of its line:
# each worker flew that module's fixture on the same vehicle ports.)
REAL_TIME_MODULES = frozenset({
    "test_agent_autopilot.py", "test_demo.py", "test_export_mission.py", "test_field_faults.py",
    "test_field_starts.py", "test_gcs_processes.py", "test_leaving_control.py", "test_num_uavs.py",
    "test_per_uav_stacks.py", "test_replanning_processes.py", "test_sitl.py",
    "test_sitl_across_hosts.py", "test_sitl_control.py", "test_sitl_px4.py",
    "test_sitl_px4_hosts.py", "test_sitl_px4_missions.py", "test_sitl_signing.py",
    "test_sitl_survey.py",
    "test_sitl_wind.py",
    "test_swarm_across_hosts.py",
    "test_ten_uavs.py"})
REAL_TIME = "real time"


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """The workers' units: every other module one unit (its module fixtures run once), all of
    REAL_TIME_MODULES one unit, the largest first. (Not xdist_group marks: pytest 9.2 drops
    the node-id suffix that --dist loadgroup groups by, pytest-xdist issue 1386.)"""
    from xdist.scheduler import LoadScopeScheduling

    class ModulesRealTimeTogether(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::", 1)[0]
            return REAL_TIME if Path(module).name in REAL_TIME_MODULES else module

    return ModulesRealTimeTogether(config, log)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """A side-by-side flight is flown by the worker that runs its test: its module must be one
    of REAL_TIME_MODULES, or another worker would fly its group again."""
    for item in items:
        if any(item.iter_markers("side_by_side")) and item.path.name not in REAL_TIME_MODULES:
            raise pytest.UsageError(f"{item.nodeid}: a side-by-side flight's module must be "
                                    "in conftest.REAL_TIME_MODULES")


@pytest.fixture(scope="session")
def side_by_side(request, tmp_path_factory):
    """The session's slow flights flown side by side (test/side_by_side.py): those whose
    tests were selected start together on the first request of their group."""
    from side_by_side import SideBySide

    selected = {m.args[0] for item in request.session.items
                for m in item.iter_markers("side_by_side")}
    flights = SideBySide(selected, tmp_path_factory.mktemp, _next_domain)
    yield flights
    flights.close()
