"""The Foxglove layout (report/foxglove_layout.py): the shipped file is the generator's output;
the tree and the panel configs agree; every topic it names is the suite's (ros/topics.py) and
is in a real recorded mission's bag (conftest's `mission`, recorded once per session), where
every plot path, evaluated as Foxglove's message-path syntax reads it, gives numbers; and
`uav-insar report` names the layout. Foxglove itself does not run here."""
from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import process_group
import pytest
import yaml
from conftest import REPO

from uav_insar_planner.report.foxglove_layout import SHIPPED, foxglove_layout, layout_json
from uav_insar_planner.swarm import DEFAULT_NUM_UAVS, MAX_UAVS, MIN_UAVS, uav_name, uavs

# Table I's swarm: this test is of three UAVs (test_num_uavs.py flies others)
UAVS = uavs(DEFAULT_NUM_UAVS)

pytestmark = pytest.mark.timeout(120)
PANEL_TYPES = {"3D", "Plot", "DiagnosticSummary", "DiagnosticStatusPanel", "RawMessages"}
MARKER_TYPE = "visualization_msgs/msg/MarkerArray"


def _leaves(node) -> list[str]:
    if isinstance(node, str):
        return [node]
    assert set(node) <= {"first", "second", "direction", "splitPercentage"}, node
    assert node["direction"] in ("row", "column") and 0 < node["splitPercentage"] < 100
    return _leaves(node["first"]) + _leaves(node["second"])


def _plot_paths(layout) -> dict[str, list[dict]]:
    return {pid: c["paths"] for pid, c in layout["configById"].items() if pid.startswith("Plot!")}


def _topics_named(layout) -> set[str]:
    config = layout["configById"]
    named = {p["value"].split(".")[0] for paths in _plot_paths(layout).values() for p in paths}
    named |= set(config["3D!markers"]["topics"])
    named |= {c["topicToRender"] for pid, c in config.items() if pid.startswith("Diagnostic")}
    named |= {c["topicPath"] for pid, c in config.items() if pid.startswith("RawMessages")}
    return named


def test_the_shipped_file_is_the_generators_output():
    assert SHIPPED.read_text() == layout_json(), \
        "regenerate it: python -m uav_insar_planner.report.foxglove_layout"


def test_setup_ships_the_file_for_pip_and_colcon():
    text = (REPO / "setup.py").read_text()
    relative = SHIPPED.relative_to(REPO / "uav_insar_planner").as_posix()
    assert f'FOXGLOVE_LAYOUT = "{relative}"' in text
    assert "package_data={package_name: [FOXGLOVE_LAYOUT]}" in text
    assert '"share/" + package_name + "/foxglove"' in text


def test_every_panel_in_the_tree_has_a_config_and_every_config_a_panel():
    layout = foxglove_layout()
    assert set(layout) == {"configById", "globalVariables", "userNodes", "playbackConfig",
                           "layout"}
    leaves = _leaves(layout["layout"])
    assert len(leaves) == len(set(leaves)) and set(leaves) == set(layout["configById"])
    assert {pid.partition("!")[0] for pid in leaves} == PANEL_TYPES


# Table I's and swarm.py's smallest and largest swarms, and six, the largest before ten
# (test_num_uavs.py reports a 5-UAV bag, test_ten_uavs.py a 10-UAV one)
SWARMS = sorted({MIN_UAVS, DEFAULT_NUM_UAVS, 6, MAX_UAVS})


@pytest.mark.parametrize("num_uavs", SWARMS)
def test_each_plot_has_one_enabled_series_per_uav(num_uavs):
    swarm = uavs(num_uavs)
    layout = foxglove_layout(num_uavs)
    assert set(_leaves(layout["layout"])) == set(layout["configById"])
    for pid, paths in _plot_paths(layout).items():
        assert [p["label"] for p in paths] == [uav_name(k) for k in swarm], pid
        for p, k in zip(paths, swarm, strict=True):
            assert p["enabled"] and p["timestampMethod"] == "receiveTime"
            assert p["value"].startswith(f"/{uav_name(k)}/") or f'"planner: {uav_name(k)}"' in \
                p["value"], p


@pytest.mark.parametrize("num_uavs", SWARMS)
def test_the_topics_are_the_suites(num_uavs):
    from uav_insar_planner.ros import topics

    swarm = uavs(num_uavs)
    layout = foxglove_layout(num_uavs)
    suite = {"/" + name for name in (topics.MARKERS, topics.FLOWN_MARKERS, topics.FORMATION)}
    suite |= {topics.DIAGNOSTICS}
    suite |= {"/" + f(k) for k in swarm for f in (topics.achieved_rate, topics.offload)}
    assert _topics_named(layout) == suite
    assert layout["configById"]["3D!markers"]["followTf"] == topics.FRAME_ID
    power = [p["value"] for p in _plot_paths(layout)["Plot!power"]]
    index = topics.OFFLOAD_FIELDS.index("power_w")
    assert power == [f"/{topics.offload(k)}.data[{index}]" for k in swarm]


@pytest.mark.parametrize("num_uavs", [0, MIN_UAVS - 1, MAX_UAVS + 1])
def test_a_count_that_is_no_swarms_is_refused(num_uavs):
    with pytest.raises(ValueError, match=f"num_uavs: value {num_uavs} UAVs is not allowed; "
                       f"expected {MIN_UAVS} to {MAX_UAVS}"):
        foxglove_layout(num_uavs)


# --- Foxglove's message-path syntax, the part the layout uses --------------------------------
_STEP = re.compile(r"""\.(\w+)|\[(-?\d+)\]|\[:\]|\{(\w+)==(?:"([^"]*)"|'([^']*)')\}""")


def _evaluate(path: str, message) -> list:
    """The values `path` (topic stripped) gives on `message`: fields, [i], [:] fan-out and
    {field=="string"} filters, as Foxglove's documented message-path syntax reads them. A
    field the message does not have raises AttributeError."""
    values, rest = [message], path
    while rest:
        m = _STEP.match(rest)
        assert m, f"unsupported message path step at {rest!r}"
        field, index, key, dq, sq = m.groups()
        if field:
            values = [getattr(v, field) for v in values]
        elif index is not None:
            values = [v[int(index)] for v in values if -len(v) <= int(index) < len(v)]
        elif key:
            wanted = dq if dq is not None else sq
            values = [v for v in values if getattr(v, key) == wanted]
        else:
            values = [item for v in values for item in v]
        rest = rest[m.end():]
    return values


def _bag_messages(bag: Path) -> tuple[dict[str, str], dict[str, list]]:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    (name,) = meta["relative_file_paths"]
    types = {t["topic_metadata"]["name"]: t["topic_metadata"]["type"]
             for t in meta["topics_with_message_count"]}
    messages: dict[str, list] = {}
    with (bag / name).open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages():
            messages.setdefault(channel.topic, []).append(msg)
    return types, messages


def test_a_recorded_mission_holds_every_topic_and_each_plot_reads_numbers(mission):
    check_layout_reads_the_bag(foxglove_layout(), mission.bag)


def check_layout_reads_the_bag(layout: dict, bag: Path) -> None:
    """Every topic `layout` names is in `bag`, the markers in its frame, and each plot path,
    evaluated as Foxglove reads it, gives finite numbers (test_ten_uavs.py: ten UAVs' bag)."""
    types, messages = _bag_messages(bag)
    assert _topics_named(layout) <= set(types), sorted(_topics_named(layout) - set(types))
    for topic in layout["configById"]["3D!markers"]["topics"]:
        assert types[topic] == MARKER_TYPE and messages[topic], topic
        frames = {m.header.frame_id for array in messages[topic] for m in array.markers}
        assert frames == {layout["configById"]["3D!markers"]["followTf"]}, (topic, frames)
    assert messages[layout["configById"]["RawMessages!formation"]["topicPath"]]
    for pid, paths in _plot_paths(layout).items():
        for p in paths:
            topic, _, rest = p["value"].partition(".")
            got = [v for msg in messages[topic] for v in _evaluate("." + rest, msg)]
            # Foxglove's Plot takes a number, or a string as JavaScript's +value reads it
            numbers = [float(v) for v in got]
            assert any(math.isfinite(x) for x in numbers), (pid, p["value"], got[:5])
    detail = layout["configById"]["DiagnosticStatusPanel!plan"]
    assert any((s.hardware_id, s.name) == (detail["selectedHardwareId"], detail["selectedName"])
               for array in messages["/diagnostics"] for s in array.status)


def test_a_missing_field_is_caught():
    class Float64:
        data = 1.0

    assert _evaluate(".data", Float64()) == [1.0]
    with pytest.raises(AttributeError):
        _evaluate(".value", Float64())


def test_report_names_the_layout(mission, tmp_path):
    proc = process_group.run([sys.executable, "-m", "uav_insar_planner.cli", "report",
                           str(mission.bag), "--out", str(tmp_path / "out"), "--no-progress"],
                          capture_output=True, text=True, timeout=90, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    last = proc.stdout.strip().splitlines()[-1]
    (mcap,) = mission.bag.glob("*.mcap")
    assert last == f"Foxglove: open {mcap}, then import the layout {SHIPPED}"
    assert SHIPPED.is_file()
