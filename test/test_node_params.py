"""Parameters of the real node processes, as a user meets them: params files and --ros-args at
start-up, and run-time sets through the nodes' rcl_interfaces services (what `ros2 param set`
and `ros2 service call` send). Every node runs on real rclpy, on the test's private domain."""
from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest
from clean_stop import stop_cleanly
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.msg import ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters, SetParametersAtomically
from std_srvs.srv import Trigger

from uav_insar_planner import load_params, solve
from uav_insar_planner.demo.processes import start_node

CONFIG = str(Path(__file__).resolve().parents[1] / "config" / "params.yaml")
N = 8


class Probe:
    """Calls the nodes' services from the test's TopicWatcher node (as ros2 param / ros2
    service call do) and sees /formation through it."""

    def __init__(self, watcher) -> None:
        self.w = watcher
        self.formations = watcher.formations

    def spin_until(self, done, timeout: float) -> bool:
        return self.w.spin_until(done, timeout)

    def call(self, srv_type, name: str, request, timeout: float = 10.0):
        answer = self.w.call(srv_type, name, request, 15.0 + timeout)
        assert answer is not None, f"{name}: no answer"
        return answer

    def set(self, node: str, name: str, value: ParameterValue):
        request = SetParameters.Request(parameters=[ParameterMsg(name=name, value=value)])
        return self.call(SetParameters, f"/{node}/set_parameters", request).results[0]

    def get(self, node: str, name: str) -> ParameterValue:
        return self.call(GetParameters, f"/{node}/get_parameters",
                         GetParameters.Request(names=[name])).values[0]


def double(v: float) -> ParameterValue:
    return ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=v)


def integer(v: int) -> ParameterValue:
    return ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=v)


def xz(msg) -> np.ndarray:
    return np.array([[p.position.x, p.position.z] for p in msg.poses])


def test_runtime_sets_replan_refuse_or_convert_as_ros2_param_set_would(watcher, procs):
    planner = procs("planner", "-p", f"num_slots:={N}")
    agent = procs("agent", "-p", f"num_slots:={N}", "-r", "__node:=agent0")
    probe = Probe(watcher)
    assert probe.spin_until(lambda: probe.formations, 30.0), "no /formation"
    base = load_params(overrides={"num_slots": N})
    assert np.allclose(xz(probe.formations[0]), solve(base).formation, atol=1e-6)

    ok = probe.set("planner", "h_amb_min_m", double(0.9))
    assert ok.successful, ok.reason
    assert probe.spin_until(lambda: len(probe.formations) >= 2, 30.0), "no replan after set"
    expected = solve(base.replace(h_amb_min_m=0.9)).formation
    assert np.allclose(xz(probe.formations[-1]), expected, atol=1e-6)

    refused = probe.set("planner", "h_amb_min_m", double(-1.0))
    assert not refused.successful
    assert "h_amb_min_m" in refused.reason and "-1.0" in refused.reason, refused.reason
    assert "> 0" in refused.reason or "0.0" in refused.reason, refused.reason
    probe.spin_until(lambda: False, 1.5)
    assert len(probe.formations) == 2, "a refused set must not replan"
    assert probe.get("planner", "h_amb_min_m").double_value == 0.9

    # An integer for a double is the double meant (ros2 param set /planner h_amb_min_m 1).
    as_int = probe.set("planner", "h_amb_min_m", integer(1))
    assert as_int.successful, as_int.reason
    got = probe.get("planner", "h_amb_min_m")
    assert (got.type, got.double_value) == (ParameterType.PARAMETER_DOUBLE, 1.0)
    assert probe.spin_until(lambda: len(probe.formations) >= 3, 30.0)

    reply = probe.call(Trigger, "/planner/replan", Trigger.Request())
    assert reply.success and "solving" in reply.message
    assert probe.spin_until(lambda: len(probe.formations) >= 4, 30.0)

    # Start-up-only parameters are refused, never "successful" and ignored.
    for node, name, value in (("agent0", "uav_id", integer(2)),
                              ("agent0", "speed_mps", double(2.0))):
        refused = probe.set(node, name, value)
        assert not refused.successful and "read-only" in refused.reason, refused.reason
    assert probe.get("agent0", "uav_id").integer_value == 0
    stop_cleanly([planner, agent])


def test_the_swarm_size_changes_at_run_time_in_one_atomic_set(watcher, procs):
    """num_uavs and its per-UAV list change together or not at all: alone, each is refused
    with the length it needs (ros2 param set sends one at a time); in one
    set_parameters_atomically call (ros2 service call) the planner replans the new swarm."""
    planner = procs("planner", "-p", f"num_slots:={N}")
    probe = Probe(watcher)
    assert probe.spin_until(lambda: probe.formations, 30.0), "no /formation"
    assert len(probe.formations[0].poses) == 3

    alone = probe.set("planner", "num_uavs", integer(5))
    assert not alone.successful and "rate_min_mbps" in alone.reason, alone.reason
    assert "list of 5" in alone.reason, alone.reason
    rates = [10.0, 16.95, 1.0, 1.0, 1.0]
    rate_list = ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY,
                               double_array_value=rates)
    both = probe.call(SetParametersAtomically, "/planner/set_parameters_atomically",
                      SetParametersAtomically.Request(parameters=[
                          ParameterMsg(name="num_uavs", value=integer(5)),
                          ParameterMsg(name="rate_min_mbps", value=rate_list)])).result
    assert both.successful, both.reason
    assert probe.spin_until(lambda: len(probe.formations) >= 2, 30.0), "no replan"
    expected = solve(load_params(overrides={"num_slots": N, "num_uavs": 5,
                                            "rate_min_mbps": rates})).formation
    assert np.allclose(xz(probe.formations[-1]), expected, atol=1e-6)
    assert probe.get("planner", "num_uavs").integer_value == 5
    stop_cleanly([planner])


def test_integer_in_params_file_is_the_double_meant(watcher, procs, tmp_path):
    f = tmp_path / "ints.yaml"
    f.write_text(f'"/**":\n  ros__parameters:\n    num_slots: {N}\n    speed_mps: 4\n'
                 "    ground_station_m: [70, 150, 25]\n")
    planner = procs("planner", "--params-file", str(f))
    probe = Probe(watcher)
    assert probe.spin_until(lambda: probe.formations, 30.0), "no /formation"
    assert probe.get("planner", "speed_mps").double_value == 4.0
    expected = solve(load_params(overrides={"num_slots": N, "speed_mps": 4.0,
                                            "ground_station_m": [70.0, 150.0, 25.0]}))
    assert np.allclose(xz(probe.formations[0]), expected.formation, atol=1e-6)
    stop_cleanly([planner])


BAD_FILES = {
    "misspelt name": ('"/**":\n  ros__parameters:\n    num_slot: 3\n',
                      "num_slot: unknown parameter", "did you mean num_slots?"),
    "section for no node": ("planer:\n  ros__parameters:\n    num_slots: 3\n",
                            "section 'planer' names no node", "did you mean planner?"),
    "empty file": ("", "is empty", "ros__parameters"),
    "not YAML": ("a: [\n", "is not valid YAML", "line"),
    "no ros__parameters": ('"/**":\n  num_slots: 3\n', "must hold a 'ros__parameters'", ""),
    "aliases": ('"/**":\n  ros__parameters:\n    ground_station_m: &g [1.0, 2.0, 3.0]\n'
                "    rate_min_mbps: *g\n", "aliases are not allowed", "line 4"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_params_file_stops_every_node_with_one_line_and_code_2(procs, tmp_path, case):
    text, what, hint = BAD_FILES[case]
    f = tmp_path / "bad.yaml"
    f.write_text(text)
    for name in ("planner", "agent", "mavlink_bridge"):
        proc = procs(name, "--params-file", str(f))
        out, _ = proc.communicate(timeout=30)
        assert proc.returncode == 2, out
        lines = out.strip().splitlines()
        assert len(lines) == 1 and "[ERROR]" in lines[0], out
        assert what in lines[0] and hint in lines[0], lines[0]
        assert "Traceback" not in out


@pytest.mark.parametrize("args,what", [
    (["--params-file", "/nonexistent/p.yaml"], "cannot be read"),
    (["-p"], "Couldn't parse trailing -p flag"),
    (["--no-such-flag"], "--no-such-flag"),
    (["-p", "num_slots:=0"], "num_slots: value 0 is not allowed"),
    (["-p", "num_slots:=2.5"], "num_slots: value 2.5 is not allowed"),
])
def test_bad_ros_args_exit_2_with_one_line(procs, args, what):
    proc = procs("planner", *args)
    out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 2, out
    errors = [line for line in out.splitlines() if "ERROR" in line]
    assert len(errors) == 1 and what in errors[0], out
    assert "Traceback" not in out


def test_domain_id_out_of_range_exits_2(ros_domain, monkeypatch):
    monkeypatch.setenv("ROS_DOMAIN_ID", "999")
    proc = start_node("planner", [], dict(os.environ))
    out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 2 and "ROS_DOMAIN_ID: value '999'" in out, out
    assert "0..232" in out


def test_domains_are_isolated(watcher, procs, another_domain):
    import rclpy

    from uav_insar_planner.ros.tools.topic_watcher import TopicWatcher

    planner = procs("planner", "-p", f"num_slots:={N}")
    other = rclpy.Context()
    rclpy.init(context=other, domain_id=another_domain)
    try:
        stranger = TopicWatcher(other, "stranger")
        assert watcher.spin_until(lambda: watcher.formations, 30.0)
        end = time.monotonic() + 3.0
        stranger.spin_until(lambda: time.monotonic() > end, 4.0)
        assert stranger.formations == []
        stranger.destroy()
    finally:
        other.try_shutdown()
    stop_cleanly([planner])


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("name", ["planner", "agent", "mavlink_bridge"])
def test_sigint_and_sigterm_stop_every_node_cleanly(watcher, procs, name, sig):
    # Count, not presence: a node of that name left on the domain by an earlier run (domains
    # wrap after 232 tests) must not pass for this one while it still starts up.
    watcher.spin_until(lambda: False, 1.0)  # discovery of whatever is already there
    before = watcher.node.get_node_names().count(name)
    proc = procs(name, "-p", f"num_slots:={N}")
    assert watcher.spin_until(lambda: watcher.node.get_node_names().count(name) > before,
                              20.0), f"{name} not up"
    proc.send_signal(sig)
    out, _ = proc.communicate(timeout=15)
    assert proc.returncode == 0, out
    assert "Traceback" not in out and "[ERROR]" not in out, out


def test_a_teardown_that_hangs_prints_its_stacks_and_ends_the_node(children):
    """Fault injected (see the script): destroy_node hangs after Ctrl-C. The node prints every
    thread's stack, then ends with its code, 0, well before the SIGTERM stop_nodes would send
    after STOP_TIMEOUT_S."""
    from uav_insar_planner.demo.processes import STOP_TIMEOUT_S
    from uav_insar_planner.ros.run import TEARDOWN_EXIT_S, TEARDOWN_MAX_S

    proc = children.start(script=Path(__file__).with_name("hang_in_teardown.py"))
    assert proc.stdout.readline().strip() == "spinning"
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    start = time.monotonic()
    out, err = proc.communicate(timeout=30)
    took = time.monotonic() - start
    assert proc.returncode == 0, err
    assert TEARDOWN_MAX_S <= took < STOP_TIMEOUT_S, took
    assert TEARDOWN_MAX_S + TEARDOWN_EXIT_S < STOP_TIMEOUT_S
    assert "in stuck_here" in err and "did not finish in" in err, err
    assert err.rstrip().endswith("exiting with code 0"), err[-300:]


def test_a_stop_signal_while_the_node_is_built_is_a_clean_stop(children):
    # The fault CI met once: SIGINT after the planner was on the graph, before its constructor
    # had made its last publisher (fault injection, see the script's docstring).
    done = children.run(script=Path(__file__).with_name("stop_while_building.py"), timeout=30)
    assert "context shut down" in done.stdout, done.stdout + done.stderr
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
