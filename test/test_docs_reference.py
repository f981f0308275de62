"""The documentation's generated reference pages (docs/_hooks/reference.py) say what the code
holds: every parameter of config/params.yaml and of every node, every topic of the registry,
every command and every exit code. No ROS graph needed; the strict build of the whole site is
test_docs.py's."""
from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from uav_insar_planner import exit_codes
from uav_insar_planner.cli import PROG, build_parser, verbs
from uav_insar_planner.param_specs.nodes import NODE_SPECS
from uav_insar_planner.param_specs.science import PARAM_SPECS
from uav_insar_planner.params_file import read_params_file, yaml_load
from uav_insar_planner.ros.topics import INTERFACE

REPO = Path(__file__).resolve().parent.parent
HOOKS = REPO / "docs" / "_hooks"
sys.path.insert(0, str(HOOKS))  # as MkDocs loads the hook: its folder on the path

import reference  # noqa: E402
import reference_commands  # noqa: E402
import reference_md  # noqa: E402
import reference_parameters  # noqa: E402
import reference_topics  # noqa: E402


@pytest.fixture(scope="module")
def pages() -> dict[str, str]:
    return {path: build() for path, build in reference.PAGES.items()}


def test_the_pages_are_the_four_of_the_nav(pages):
    nav = (REPO / "mkdocs.yml").read_text()
    assert all(f": {path}\n" in nav for path in pages)
    assert set(pages) == {f"reference/{n}.md" for n in
                          ("parameters", "topics", "commands", "exit-codes")}
    assert not any((REPO / "docs" / path).exists() for path in pages), "generated, not files"


def test_every_parameter_of_the_params_file_is_on_the_page_with_its_value(pages):
    page = pages["reference/parameters.md"]
    values = read_params_file(REPO / "config" / "params.yaml")
    assert set(values) == {s.name for s in PARAM_SPECS}
    for name, value in values.items():
        row = re.search(rf'^\| <a id="{name}"></a>`{name}` \| [^|]+ \| `([^`]+)` \|', page, re.M)
        assert row, name
        assert yaml_load(f"v: {row.group(1)}") == {"v": value}, name


def test_every_parameter_of_every_node_has_its_row_and_anchor(pages):
    page = pages["reference/parameters.md"]
    where = reference_parameters.anchors()
    specs = reference_parameters.every_spec()
    assert {id(s) for s in specs} <= set(where), "a node's parameter in no group"
    assert len(set(where.values())) == len(where), "anchors are unique"
    for spec in specs:
        row = next(line for line in page.splitlines()
                   if line.startswith(f'| <a id="{where[id(spec)]}"></a>'))
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", row)[1:-1]]
        assert cells[1] == reference_parameters.ros_type(spec)
        assert yaml_load(f"v: {cells[2].strip('`')}") == {"v": spec.default}, spec.name
        assert cells[4].startswith(reference_md.text(spec.allowed())), spec.name
        assert all(f"[`{node}`]" in cells[5] for node in NODE_SPECS if spec in NODE_SPECS[node])


def test_units_come_out_of_the_descriptions():
    found = {s.name: reference_parameters.unit_and_description(s)
             for s in reference_parameters.every_spec()}
    assert found["slot_duration_s"] == ("s", "delta_t, slot duration")
    assert found["z_min_m"] == ("m", "z_min, lowest flying altitude (C1)")
    assert found["max_speed_mps"] == ("m/s", "speed limit, at least speed_mps")
    assert found["num_slots"] == ("", "N, number of time slots")
    assert found["offloading"][0] == ""  # P_com[k][n] is no unit


@pytest.mark.parametrize("value", [0.0, -1.0, 4.3, 1e9, 2.5e9, 1e-4, 1e-300, 123456.789, 80,
                                   True, "", "off", "a b", "udpin:1.2.3.4:5", [1.0, -2.0],
                                   ["udpout:127.0.0.1:14552"], [2, 3, 4]])
def test_defaults_are_written_as_a_params_file_reads_them(value):
    assert yaml_load(f"v: {reference_parameters.yaml_value(value)}") == {"v": value}


def test_every_registry_topic_and_service_is_on_the_page(pages):
    page = pages["reference/topics.md"]
    for spec in INTERFACE:
        shown = reference_topics.shown_name(spec)
        start = f'| <a id="{reference_topics.topic_anchor(spec)}"></a>`{shown}`'
        row = next((line for line in page.splitlines() if line.startswith(start)), None)
        assert row, shown
        assert f"`{spec.msg_type}`" in row
        if not spec.is_service:
            assert f"(`{spec.qos}`)" in row


def test_every_command_has_its_help_on_the_page(pages):
    page = pages["reference/commands.md"]
    top, verb_parsers = build_parser(verbs())
    assert reference_commands.help_text(top).rstrip() in page
    for name, parser in verb_parsers.items():
        assert f"### `{PROG} {name}`" in page
        assert reference_commands.help_text(parser).rstrip() in page, name
    for title in (reference_commands.DEMO, "uav-insar-vehicle", *NODE_SPECS):
        assert f"### `{title}`" in page
    assert "usage: uav-insar-vehicle" in page and "usage: python -m uav_insar_planner.demo" in page


def test_every_exit_code_is_on_the_page(pages):
    page = pages["reference/exit-codes.md"]
    constants = {n: v for n, v in vars(exit_codes).items() if re.fullmatch(r"EXIT_[A-Z_]+", n)
                 and isinstance(v, int)}
    assert {(n, c) for n, c, _ in exit_codes.EXIT_CODE_TABLE} == set(constants.items())
    for name, code, meaning in exit_codes.EXIT_CODE_TABLE:
        assert f'| <a id="exit-{code}"></a>{code} | `{name}` | {reference_md.text(meaning)} |' \
            in page


def test_headings_get_the_ids_python_markdown_gives_them():
    toc = pytest.importorskip("markdown.extensions.toc")
    for title in ("`uav-insar plot-formation`", "python -m uav_insar_planner.demo",
                  "mavlink_bridge", "Agent, MAVLink mode"):
        assert reference_md.heading_id(title) == toc.slugify(title.replace("`", ""), "-")


def test_cells_escape_what_markdown_would_take_for_markup():
    assert reference_md.text("a | b <x> P_com[k] `c|<d>`") == r"a \| b &lt;x> P\_com\[k\] `c|<d>`"
    assert reference_md.text("odd ` tick") == r"odd \` tick"


def test_recording_md_lists_every_topic_of_the_registry_as_a_demo_bag_names_it():
    """The topic list of recording.md is generated (reference.INSERTS) from ros/topics.py:
    the page holds only its marker, the built page every topic (25 for Table I's swarm: 7
    of the swarm and 6 per UAV), services not."""
    from types import SimpleNamespace

    from uav_insar_planner.swarm import DEFAULT_NUM_UAVS

    source = (REPO / "docs" / "recording.md").read_text()
    ((marker, _),) = reference.INSERTS["recording.md"].items()
    assert source.count(marker) == 1
    assert "/uavK/mavlink/pose" not in source  # no hand-written list beside it
    page = SimpleNamespace(file=SimpleNamespace(src_uri="recording.md"))
    built = reference.on_page_markdown(source, page, None, None)
    assert marker not in built
    topics = [s for s in INTERFACE if not s.is_service]
    names = reference_topics.recorded_names()
    shared = sum(not s.per_uav for s in topics)
    assert len(names) == len(set(names)) == shared + (len(topics) - shared) * DEFAULT_NUM_UAVS
    assert len(names) == 25  # the demo bag of issue 27
    for name in names:
        assert f"[`{name}`](reference/topics.md#" in built, name
    assert f"holds these {len(names)} topics" in built
    assert not any(f"`{shown}`" in built for s in INTERFACE if s.is_service
                   for shown in [reference_topics.shown_name(s)])
    with pytest.raises(ValueError, match="recording.md: the line"):
        reference.on_page_markdown(source.replace(marker, ""), page, None, None)


def test_solvers_md_tables_every_declared_back_end():
    """The back-end table of science/solvers.md is generated (reference.INSERTS) from
    param_specs.science.BACKENDS: each back end once, with its objectives and certificate."""
    from types import SimpleNamespace

    from uav_insar_planner.param_specs.science import BACKENDS

    source = (REPO / "docs" / "science" / "solvers.md").read_text()
    ((marker, build),) = reference.INSERTS["science/solvers.md"].items()
    assert source.count(marker) == 1
    page = SimpleNamespace(file=SimpleNamespace(src_uri="science/solvers.md"))
    table = build()
    assert table.rstrip("\n") in reference.on_page_markdown(source, page, None, None)
    rows = [line for line in table.splitlines() if line.startswith("| `")][1:]  # no header
    assert [row.split("|")[1].strip() for row in rows] == [f"`{b.name}`" for b in BACKENDS]
    multilook = [row.split("|")[1].strip() for row in rows if "`multilook`" in row]
    assert multilook == ["`global`"]
    assert [row.split("|")[3].strip() for row in rows] == ["yes", "no", "no"]


def test_launch_md_tables_every_argument_of_every_launch_file():
    """The arguments on ros/launch.md are generated (reference.INSERTS) from
    ros.launch_files.LAUNCH_FILES, from which the launch files declare them (test_launch.py
    compares that with `ros2 launch --show-args`): one section per file of launch/, a row per
    argument with its default."""
    from types import SimpleNamespace

    from uav_insar_planner.ros.launch_files import LAUNCH_FILES

    assert sorted(LAUNCH_FILES) == sorted(p.name for p in (REPO / "launch").glob("*.launch.py"))
    source = (REPO / "docs" / "ros" / "launch.md").read_text()
    ((marker, build),) = reference.INSERTS["ros/launch.md"].items()
    assert source.count(marker) == 1
    page = SimpleNamespace(file=SimpleNamespace(src_uri="ros/launch.md"))
    text = build()
    assert text.rstrip("\n") in reference.on_page_markdown(source, page, None, None)
    sections = text.split("### ")[1:]
    assert [s.split("`")[1] for s in sections] == list(LAUNCH_FILES)
    for section, spec in zip(sections, LAUNCH_FILES.values(), strict=True):
        rows = [line.split(" | ") for line in section.splitlines() if line.startswith("| `")]
        assert [(r[0][2:].strip("`"), r[1]) for r in rows] == [
            (a.name, "required" if a.default is None else f"`{a.default}`" if a.default
             else "empty") for a in spec.args]
