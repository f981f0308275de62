"""One params-file reader: every file gets the same verdict, and the same line or the same
values, from the command line (`uav-insar solve/sweep/report --params`, the demo's
`--params-file`) and from the node processes (`planner/agent/mavlink_bridge --ros-args
--params-file`), which rclpy then reads on its own: the values a running planner reports are
the ones the reader returned. A name is judged alike everywhere: one that no node takes gets
`params.unknown_parameter`'s line from each, one that another node takes is left to it."""
from __future__ import annotations

import signal
import subprocess
import sys

import process_group
import pytest
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters, ListParameters

from uav_insar_planner.param_specs.nodes import NODE_SPECS, RCLPY_PARAMETER_NAMES, nodes_taking
from uav_insar_planner.param_specs.science import SPEC_BY_NAME
from uav_insar_planner.params import ParamError, unknown_parameter
from uav_insar_planner.params_file import (
    load_params,
    params_file_problems,
    read_params_file,
    section_matches,
)
from uav_insar_planner.swarm import MAX_UAVS, agent_name

CLI = [sys.executable, "-m", "uav_insar_planner.cli"]
N = 8
BASE = f'"/**":\n  ros__parameters:\n    num_slots: {N}\n'
# Parameters of the agent, the bridge, the planner alone and rclpy, none of them the scenario's
# and none set by the demo itself: every reader takes its own and leaves the rest.
OTHER_NODES = ("    max_speed_mps: 12.0\n    heartbeat_timeout_s: 6.0\n    uav_timeout_s: 3.0\n"
               "    use_sim_time: false\n")
NODES = ("planner", "agent", "mavlink_bridge")

# name: (file text, namespace the node runs in, expected: the one error line's gist, or the
# values of the node in that namespace).
CASES = {
    "misspelt section": ("planer:\n  ros__parameters:\n    num_slots: 3\n", "",
                         "section 'planer' names no node of uav_insar_planner (did you mean "
                         "planner?)"),
    "misspelt under a wildcard": (BASE + "/**/planer:\n  ros__parameters:\n    looks: 3\n", "",
                                  "section '/**/planer' names no node of uav_insar_planner "
                                  "(did you mean planner?)"),
    "agent beyond the largest swarm": (
        BASE + f"{agent_name(MAX_UAVS)}:\n  ros__parameters:\n    speed_mps: 4.0\n", "",
        f"section '{agent_name(MAX_UAVS)}' names no node"),
    "empty file": ("", "", "is empty; expected '/**:' or 'NODE:' sections"),
    "list at top level": ("- planner\n- agent\n", "", "must map node names to"),
    "no ros__parameters": ('"/**":\n  num_slots: 3\n', "",
                           "section '/**' must hold a 'ros__parameters' mapping"),
    "more than ros__parameters": ("planner:\n  ros__parameters:\n    looks: 3\n  extra:\n"
                                  "    ros__parameters:\n      looks: 4\n", "",
                                  "section 'planner' must hold only a 'ros__parameters'"),
    "not a node name": ('"plan*":\n  ros__parameters:\n    looks: 3\n', "",
                        "section 'plan*' is not a node name"),
    "slash inside a namespace": ("ns:\n  /planner:\n    ros__parameters:\n      looks: 3\n", "",
                                 "section 'ns//planner' is not a node name"),
    "misspelt name": (BASE + "    num_slot: 3\n", "", unknown_parameter("num_slot")),
    "misspelt nested name": (BASE + "    lookz:\n      n: 3\n", "", unknown_parameter("lookz.n")),
    # a mapping where a node's parameter is: one line saying what is expected, not one
    # "unknown parameter 'ground_station_m.x'" per key (issue 27)
    "mapping for a list": (BASE + "    ground_station_m: {x: 1, y: 2, z: 3}\n", "",
                           "section '/**': ground_station_m: value {'x': 1, 'y': 2, 'z': 3} "
                           "is not allowed (a mapping); expected a list of 3 finite numbers"),
    "mapping for a number": (BASE + "    looks:\n      n: 3\n", "",
                             "looks: value {'n': 3} is not allowed (a mapping); expected an "
                             "integer"),
    "list of mixed types": (BASE + "planner:\n  ros__parameters:\n"
                            "    ground_station_m: [70, 150.5, 25]\n", "",
                            "ground_station_m: value [70, 150.5, 25] mixes floats and "
                            "integers"),
    "only /**": (BASE + "    looks: 3\n", "", {"num_slots": N, "looks": 3}),
    # The section addresses /ns/planner: a planner at /planner gets nothing from it, as from
    # an agent's section; one started with -r __ns:=/ns takes it.
    "nested namespace": (BASE + "ns:\n  planner:\n    ros__parameters:\n      looks: 3\n", "",
                         {"num_slots": N, "looks": 4}),
    "nested namespace, node in it": (BASE + "ns:\n  planner:\n    ros__parameters:\n"
                                     "      looks: 3\n", "/ns", {"num_slots": N, "looks": 3}),
    "namespace three deep": (BASE + "a:\n  b:\n    c:\n      planner:\n        "
                             "ros__parameters:\n          looks: 5\n", "/a/b/c",
                             {"num_slots": N, "looks": 5}),
    "wildcards": (BASE + "/**/planner:\n  ros__parameters:\n    looks: 2\n"
                  "/*/planner:\n  ros__parameters:\n    speed_mps: 5.0\n", "",
                  {"num_slots": N, "looks": 2, "speed_mps": 4.3}),
    "one-part wildcard, node in a namespace": (BASE + "/*/planner:\n  ros__parameters:\n"
                                               "    speed_mps: 5.0\n", "/ns",
                                               {"num_slots": N, "speed_mps": 5.0}),
    # rcl merges the matching sections in file order, a later one winning: `/**` after the
    # node's own section overrides it.
    "later section wins": (f"planner:\n  ros__parameters:\n    looks: 2\n    num_slots: {N}\n"
                           '"/**":\n  ros__parameters:\n    looks: 6\n'
                           "/planner:\n  ros__parameters:\n    d_min_m: 2.0\n", "",
                           {"num_slots": N, "looks": 6, "d_min_m": 2.0}),
    "every node's names under /**": (BASE + OTHER_NODES, "", {"num_slots": N}),
    # launch_ros writes a node's dict of parameters under its own name: a shared dict puts
    # the others' names there too.
    "another node's name in the planner's section": (
        BASE + "planner:\n  ros__parameters:\n    mavlink_listen: ''\n    looks: 3\n", "",
        {"num_slots": N, "looks": 3}),
    "agents' sections": (BASE + "agent0:\n  ros__parameters:\n    looks: 7\n"
                         "agent2:\n  ros__parameters:\n    looks: 9\n", "",
                         {"num_slots": N, "looks": 4}),
}
ERRORS = sorted(k for k, v in CASES.items() if isinstance(v[2], str))
ACCEPTED = sorted(k for k, v in CASES.items() if isinstance(v[2], dict))


def _file(tmp_path, case: str) -> str:
    path = tmp_path / "case.yaml"
    path.write_text(CASES[case][0])
    return str(path)


def _error_lines(text: str, prefix: str) -> list[str]:
    """The lines of `text` that start with `prefix`, without it (node lines: after ']: ')."""
    return [line.split("]: ", 1)[1] if prefix == "[ERROR]" else line[len(prefix):]
            for line in text.splitlines() if line.startswith(prefix)]


@pytest.mark.parametrize("case", ERRORS)
def test_refused_file_gets_one_line_and_exit_2_from_every_reader(procs, tmp_path, case):
    path = _file(tmp_path, case)
    with pytest.raises(ParamError) as exc:
        load_params(path)
    assert len(exc.value.problems) == 1 and CASES[case][2] in exc.value.problems[0]
    line = exc.value.problems[0]
    assert line.startswith(f"params file {path!r}: ") or "unknown parameter" in line, line
    commands = {"solve": [*CLI, "solve", "--params", path],
                "sweep": [*CLI, "sweep", "looks", "1", "2", "2", "--params", path],
                "report": [*CLI, "report", str(tmp_path / "no_bag"), "--params", path],
                "demo": [sys.executable, "-m", "uav_insar_planner.demo", "--params-file", path]}
    prefixes = {"demo": ""}
    for name, cmd in commands.items():
        proc = process_group.run(cmd, capture_output=True, text=True, timeout=60)
        assert proc.returncode == 2, (name, proc.stderr)
        assert _error_lines(proc.stderr, prefixes.get(name, "uav-insar: error: ")) == [line], \
            (name, proc.stderr)
        assert proc.stdout == "", (name, proc.stdout)
    for node in NODES:
        _assert_refused(procs(node, "--params-file", path), node, line)


def _assert_refused(proc: subprocess.Popen, node: str, line: str) -> None:
    """The node stopped with exit 2 and said `line` alone, as run.py or its logger does."""
    out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 2, (node, out)
    lines = out.strip().splitlines()
    assert all(f"[{node}]: " in text for text in lines), (node, out)
    assert _error_lines(out, "[ERROR]") == [line], (node, out)


def _value(v):
    return {ParameterType.PARAMETER_INTEGER: v.integer_value,
            ParameterType.PARAMETER_DOUBLE: v.double_value}[v.type]


@pytest.mark.parametrize("case", ACCEPTED)
def test_accepted_file_gives_the_node_the_values_the_reader_returns(watcher, procs, tmp_path,
                                                                     case):
    path = _file(tmp_path, case)
    namespace, expected = CASES[case][1], CASES[case][2]
    fqn = f"{namespace}/planner"
    params = load_params(path, node_name=fqn)
    assert {k: params.raw[k] for k in expected} == expected
    assert {k for k in read_params_file(path, fqn) if k in SPEC_BY_NAME} <= set(expected)
    if not namespace:
        cli = process_group.run([*CLI, "solve", "--params", path, "--json"], capture_output=True,
                             text=True, timeout=120)
        assert cli.returncode == 0, cli.stderr
    args = ["-r", f"__ns:={namespace}"] if namespace else []
    planner = procs("planner", "--params-file", path, *args)
    answer = watcher.call(GetParameters, f"{fqn}/get_parameters",
                          GetParameters.Request(names=list(expected)), 30.0)
    assert answer is not None, f"no answer from {fqn}"
    got = dict(zip(expected, map(_value, answer.values), strict=True))
    assert got == expected
    planner.send_signal(signal.SIGINT)
    out, _ = planner.communicate(timeout=20)
    assert planner.returncode == 0 and "[ERROR]" not in out, out


@pytest.mark.parametrize("name,fqn,matches", [
    ("/**", "/planner", True), ("/**", "/a/b/planner", True), ("**", "/planner", True),
    ("*", "/planner", True), ("/*", "/ns/planner", False),
    ("planner", "/planner", True), ("/planner", "/planner", True),
    ("planner", "/ns/planner", False), ("ns/planner", "/ns/planner", True),
    ("/**/planner", "/planner", True), ("/**/planner", "/a/b/planner", True),
    ("/*/planner", "/planner", False), ("/*/planner", "/ns/planner", True),
    ("/ns/*", "/ns/agent0", True), ("/ns/*", "/agent0", False),
    ("agent", "/agent0", False),
])
def test_sections_match_nodes_as_rclpy_does(name, fqn, matches):
    assert section_matches(name, fqn) is matches


def test_a_file_launch_ros_writes_reads_as_rcl_reads_it(tmp_path):
    """launch_ros writes a launch file's parameter dict with its lists as `!!python/tuple`
    (test_launch.py starts the nodes so); rcl reads them as lists, and so does the reader.
    Other Python tags stay refused: a params file holds no objects."""
    path = tmp_path / "launch_params"
    path.write_text("/**:\n  ros__parameters:\n    num_uavs: 2\n    rate_min_mbps: "
                    "!!python/tuple\n    - 10.0\n    - 16.95\n    connections: !!python/tuple\n"
                    "    - udpout:127.0.0.1:34100\n")
    assert read_params_file(path, "/agent0") == {
        "num_uavs": 2, "rate_min_mbps": [10.0, 16.95], "connections": ["udpout:127.0.0.1:34100"]}
    path.write_text("/**:\n  ros__parameters:\n    num_uavs: !!python/object:os.stat_result {}\n")
    assert params_file_problems(path) and "is not a params file" in params_file_problems(path)[0]


def _started(watcher, proc: subprocess.Popen, node: str) -> set[str]:
    """The node came up, and stops with 0 and no error; the names of its parameters."""
    client = watcher.node.create_client(ListParameters, f"/{node}/list_parameters")
    assert watcher.spin_until(lambda: client.service_is_ready() or proc.poll() is not None,
                              30.0) and proc.poll() is None, (node, proc.communicate()[0])
    watcher.node.destroy_client(client)
    answer = watcher.call(ListParameters, f"/{node}/list_parameters", ListParameters.Request())
    assert answer is not None, f"no answer from /{node}"
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=20)
    assert proc.returncode == 0 and "[ERROR]" not in out, (node, out)
    return set(answer.result.names)


def _demo(ros_domain: int, *args: str) -> subprocess.CompletedProcess:
    return process_group.run([sys.executable, "-m", "uav_insar_planner.demo", "--num-slots",
                           str(N), "--time-scale", "40", "--no-mavlink", "--no-bag",
                           "--domain-id", str(ros_domain), *args],
                          capture_output=True, text=True, timeout=90)


# NAME:=VALUE: the verdict of each reader, as `uav-insar solve --set NAME=VALUE`, the demo's
# and each node's `-p NAME:=VALUE`: None (accepted), or the one line it stops with (exit 2).
# `solve --set` takes the planner's verdict: the planner node leaves another node's parameter
# to that node (rclpy's -p serves every node of a process), so solve ignores it too, whatever
# its value; the node that takes it judges the value. The demo sets the agents' offloading
# itself (--offloading), so there the name is refused with the option to use.
OVERRIDES = {
    "misspelt name": ("num_slot:=3", dict.fromkeys(
        ("solve", "demo", *NODES), unknown_parameter("num_slot"))),
    "another node's name": ("max_speed_mps:=12.0", dict.fromkeys(("solve", "demo", *NODES))),
    "another node's name, a value it refuses": ("offloading:=true", {
        "solve": None, "planner": None, "mavlink_bridge": None,
        "agent": "offloading: value True is not allowed; expected one of open, closed",
        "demo": "-p offloading: value True is not allowed in the demo, which sets it on the "
                "agents itself; expected --offloading"}),
}


@pytest.mark.parametrize("case", sorted(OVERRIDES))
def test_an_override_gets_the_same_verdict_from_every_reader(watcher, procs, ros_domain, case):
    text, verdicts = OVERRIDES[case]
    solve = process_group.run([*CLI, "solve", "--set", text.replace(":=", "="), "--set",
                            f"num_slots={N}"], capture_output=True, text=True, timeout=120)
    demo = _demo(ros_domain, "-p", text)
    for name, proc, prefix in (("solve", solve, "uav-insar: error: "), ("demo", demo, "")):
        if verdicts[name] is None:
            assert proc.returncode == 0 and "error:" not in proc.stderr, (name, proc.stderr)
        else:
            assert proc.returncode == 2, (name, proc.stdout, proc.stderr)
            assert _error_lines(proc.stderr, prefix) == [verdicts[name]], (name, proc.stderr)
    for node in NODES:
        proc = procs(node, "-p", text, "-p", f"num_slots:={N}")
        if verdicts[node] is None:
            _started(watcher, proc, node)
        else:
            _assert_refused(proc, node, verdicts[node])


def test_a_file_for_every_node_serves_every_node_and_the_demo(watcher, procs, ros_domain,
                                                              tmp_path):
    path = tmp_path / "suite.yaml"
    path.write_text(BASE + OTHER_NODES + "agent0:\n  ros__parameters:\n    noise_seed: 3\n")
    assert load_params(path).num_slots == N
    for node in NODES:  # and the table of who takes what is what each node declares
        names = _started(watcher, procs(node, "--params-file", str(path)), node)
        assert names == {s.name for s in NODE_SPECS[node]} | set(RCLPY_PARAMETER_NAMES), node
    demo = _demo(ros_domain, "--params-file", str(path))
    assert demo.returncode == 0, demo.stdout + demo.stderr


def test_the_demo_refuses_a_value_it_would_override_itself(tmp_path):
    path = tmp_path / "closed.yaml"
    path.write_text(BASE + "agent1:\n  ros__parameters:\n    offloading: closed\n")
    assert load_params(path).num_slots == N  # the planner's scenario: not its parameter
    demo = process_group.run([sys.executable, "-m", "uav_insar_planner.demo", "--params-file",
                           str(path)], capture_output=True, text=True, timeout=60)
    assert demo.returncode == 2 and demo.stdout == "", demo.stdout
    assert demo.stderr.splitlines() == [
        f"params file {str(path)!r}: offloading: value 'closed' is not allowed in the demo, "
        "which sets it on the agents itself; expected --offloading"]


@pytest.mark.parametrize("name,nodes", [
    ("speed_mps", NODES), ("looks", ("planner",)), ("uav_timeout_s", ("planner",)),
    ("num_slots", ("planner", "agent")), ("offloading", ("agent",)),
    ("origin_ned_m", ("agent", "mavlink_bridge")), ("connections", ("mavlink_bridge",)),
    ("use_sim_time", NODES), ("num_slot", ()),
])
def test_the_table_says_which_nodes_take_a_name(name, nodes):
    assert nodes_taking(name) == nodes
