"""Parameters: params files with `/**` and node sections, -p overrides, remaps, ranges,
set callbacks, and bad --ros-args exiting with code 2 and one line."""
from __future__ import annotations

import json

import pytest

from uav_insar_planner import rt
from uav_insar_planner.rt.exceptions import (
    InvalidParameterTypeException,
    InvalidParameterValueException,
    ParameterNotDeclaredException,
)
from uav_insar_planner.rt.parameter import (
    FloatingPointRange,
    IntegerRange,
    Parameter,
    ParameterDescriptor,
)

PARAMS = """\
/**:
  ros__parameters:
    speed_mps: 5.0
    num_slots: 40
    scheme: static-power
    bandwidth_hz: 1e9
planner:
  ros__parameters:
    num_slots: 60
/other_node:
  ros__parameters:
    scheme: fixed-master
"""


def test_params_file_sections_and_p_override(children, tmp_path):
    path = tmp_path / "params.yaml"
    path.write_text(PARAMS)
    result = children.run("params", "--ros-args", "--params-file", str(path),
                          "-p", "speed_mps:=7.5", "-p", "ground_station_m:=[1.0, 2.0, 3.0]")
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout)
    assert out["node"] == "/planner"
    assert out["values"] == {"speed_mps": 7.5, "num_slots": 60, "scheme": "static-power",
                             "ground_station_m": [1.0, 2.0, 3.0], "bandwidth_hz": 1e9}


def test_node_and_namespace_remap_select_sections(children, tmp_path):
    path = tmp_path / "params.yaml"
    path.write_text("/swarm/brain:\n  ros__parameters:\n    num_slots: 7\n")
    result = children.run("params", "--ros-args", "-r", "__node:=brain", "-r", "__ns:=/swarm",
                          "--params-file", str(path))
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout)
    assert out["node"] == "/swarm/brain"
    assert out["values"]["num_slots"] == 7


def test_out_of_range_override_is_rejected(children):
    result = children.run("params", "--ros-args", "-p", "speed_mps:=250.0")
    assert result.returncode != 0
    assert "speed_mps" in result.stderr and "250.0" in result.stderr


@pytest.mark.parametrize("args", [
    ["--ros-args", "--bogus"],
    ["--ros-args", "-p", "speed_mps"],
    ["--ros-args", "-p"],
    ["--ros-args", "--params-file", "/nonexistent/params.yaml"],
    ["--ros-args", "-r", "__node"],
    ["--ros-args", "--log-level", "chatty"],
])
def test_bad_ros_args_exit_2_with_one_line(children, args):
    result = children.run("params", *args)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "error" in lines[0], result.stderr
    assert result.stdout == ""


def test_bad_yaml_params_file_exits_2(children, tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("/**:\n  ros__parameters:\n    speed_mps: [1.0, 'x'\n")
    result = children.run("params", "--ros-args", "--params-file", str(path))
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1


def test_declare_get_set_ranges_and_callbacks(rt_context):
    node = rt.Node("tuner", context=rt_context, parameter_overrides=[
        Parameter("rate_min_mbps", value=[10.0, 16.95, 1.0])])
    fp = ParameterDescriptor(floating_point_range=[
        FloatingPointRange(from_value=0.0, to_value=90.0, step=0.0)])
    ip = ParameterDescriptor(integer_range=[IntegerRange(from_value=1, to_value=100, step=1)],
                             read_only=False)
    assert node.declare_parameter("look_angle_deg", 45.0, fp).value == 45.0
    assert node.declare_parameter("num_slots", 80, ip).value == 80
    assert node.declare_parameter("rate_min_mbps", [1.0, 1.0, 1.0]).value == [10.0, 16.95, 1.0]
    seen = []

    def veto(params):
        seen.append([p.name for p in params])
        ok = all(p.name != "num_slots" or p.value != 13 for p in params)
        return rt.parameter.SetParametersResult(successful=ok, reason="" if ok else "unlucky")

    node.add_on_set_parameters_callback(veto)
    [ok] = node.set_parameters([Parameter("look_angle_deg", value=30.0)])
    assert ok.successful and node.get_parameter("look_angle_deg").value == 30.0
    [bad] = node.set_parameters([Parameter("look_angle_deg", value=95.0)])
    assert not bad.successful and "range" in bad.reason
    [wrong] = node.set_parameters([Parameter("look_angle_deg", value=30)])
    assert not wrong.successful and "type" in wrong.reason
    [vetoed] = node.set_parameters([Parameter("num_slots", value=13)])
    assert not vetoed.successful and vetoed.reason == "unlucky"
    assert node.get_parameter("num_slots").value == 80
    assert seen == [["look_angle_deg"], ["num_slots"]]
    with pytest.raises(InvalidParameterValueException):
        node.declare_parameter("z_max_m", 500.0, ParameterDescriptor(floating_point_range=[
            FloatingPointRange(from_value=0.0, to_value=100.0, step=0.0)]))
    with pytest.raises(ParameterNotDeclaredException):
        node.get_parameter("nope")
    typed = rt.Node("typed", context=rt_context,
                    parameter_overrides=[Parameter("speed_mps", value=4)])
    with pytest.raises(InvalidParameterTypeException):
        typed.declare_parameter("speed_mps", 4.3)
