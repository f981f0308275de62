"""One params-file reader: every file gets the same verdict, and the same line or the same
values, from the command line (`uav-insar solve/sweep/report --params`, the demo's
`--params-file`) and from the node processes (`planner/agent/mavlink_bridge --ros-args
--params-file`), which rclpy then reads on its own: the values a running planner reports are
the ones the reader returned."""
from __future__ import annotations

import signal
import subprocess
import sys

import pytest
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters

from uav_insar_planner.params import ParamError
from uav_insar_planner.params_file import load_params, read_params_file, section_matches

CLI = [sys.executable, "-m", "uav_insar_planner.cli"]
N = 8
BASE = f'"/**":\n  ros__parameters:\n    num_slots: {N}\n'

# name: (file text, namespace the node runs in, expected: the one error line's gist, or the
# values of the node in that namespace).
CASES = {
    "misspelt section": ("planer:\n  ros__parameters:\n    num_slots: 3\n", "",
                         "section 'planer' names no node of uav_insar_planner (did you mean "
                         "planner?)"),
    "misspelt under a wildcard": (BASE + "/**/planer:\n  ros__parameters:\n    looks: 3\n", "",
                                  "section '/**/planer' names no node of uav_insar_planner "
                                  "(did you mean planner?)"),
    "agent beyond the swarm": (BASE + "agent3:\n  ros__parameters:\n    speed_mps: 4.0\n", "",
                               "section 'agent3' names no node"),
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
    assert line.startswith(f"params file {path!r}: "), line
    commands = {"solve": [*CLI, "solve", "--params", path],
                "sweep": [*CLI, "sweep", "looks", "1", "2", "2", "--params", path],
                "report": [*CLI, "report", str(tmp_path / "no_bag"), "--params", path],
                "demo": [sys.executable, "-m", "uav_insar_planner.demo", "--params-file", path]}
    prefixes = {"demo": ""}
    for name, cmd in commands.items():
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
        assert proc.returncode == 2, (name, proc.stderr)
        assert _error_lines(proc.stderr, prefixes.get(name, "uav-insar: error: ")) == [line], \
            (name, proc.stderr)
        assert proc.stdout == "", (name, proc.stdout)
    for node in ("planner", "agent", "mavlink_bridge"):
        proc = procs(node, "--params-file", path)
        out, _ = proc.communicate(timeout=30)
        assert proc.returncode == 2, (node, out)
        assert out.strip().splitlines() == [f"[ERROR] [{node}]: {line}"], (node, out)


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
    assert set(read_params_file(path, fqn)) <= set(expected)
    if not namespace:
        cli = subprocess.run([*CLI, "solve", "--params", path, "--json"], capture_output=True,
                             text=True, timeout=120)
        assert cli.returncode == 0, cli.stderr
    args = ["-r", f"__ns:={namespace}"] if namespace else []
    planner = procs("planner", "--params-file", path, *args)
    client = watcher.node.create_client(GetParameters, f"{fqn}/get_parameters")
    assert watcher.spin_until(client.service_is_ready, 20.0), f"no {fqn}"
    future = client.call_async(GetParameters.Request(names=list(expected)))
    assert watcher.spin_until(future.done, 10.0)
    got = dict(zip(expected, map(_value, future.result().values), strict=True))
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
