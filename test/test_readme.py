"""The README says what the code does: one parameter table per node that matches the specs,
and no reference to a file that is not in the tree."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from uav_insar_planner.param_specs import AGENT_SPECS, BRIDGE_SPECS, MAVLINK_SPECS, PLANNER_SPECS
from uav_insar_planner.params import PARAM_SPECS
from uav_insar_planner.params_file import yaml_load

REPO = Path(__file__).resolve().parent.parent
README = (REPO / "README.md").read_text()


def table_after(heading: str) -> dict[str, list[str]]:
    """name -> cells of the first markdown table after `heading`."""
    text = README[README.index(heading + "\n"):]
    rows: dict[str, list[str]] = {}
    for line in text.splitlines()[1:]:
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip("|").split("|")]
            name = cells[0].strip("`")
            if name not in ("name", "---"):
                rows[name] = cells
        elif rows:
            break
    return rows


def test_the_parameter_table_is_the_spec_table():
    rows = table_after("## Parameters")
    assert list(rows) == [s.name for s in PARAM_SPECS]
    for spec in PARAM_SPECS:
        assert yaml_load(rows[spec.name][1].strip("`")) == spec.default, spec.name
    assert README.count("| `num_slots` |") == 1, "Table I is documented once"


@pytest.mark.parametrize("heading,specs", [
    ("### Agent parameters", AGENT_SPECS + MAVLINK_SPECS),
    ("#### Planner-only parameters", PLANNER_SPECS),
    ("### `mavlink_bridge` parameters", BRIDGE_SPECS)])
def test_node_tables_list_each_parameter_of_the_node(heading, specs):
    assert set(table_after(heading)) == {s.name for s in specs}


def test_every_file_the_readme_names_exists():
    named = set(re.findall(r"`((?:[\w-]+/)+[\w.-]+\.(?:py|yaml|md|xml|cfg|toml))`", README))
    named |= set(re.findall(r"`((?:test|benchmarks|config)/[\w.-]+)`", README))
    bases = (REPO, REPO / "uav_insar_planner", REPO / "uav_insar_planner" / "solver")
    missing = [p for p in sorted(named) if not p.startswith("../")
               and not any((base / p).exists() for base in bases)]
    assert not missing, missing
    assert "DESIGN.md" not in README and "docs/" not in README


def test_the_layout_map_names_every_module():
    layout = README[README.index("## Layout\n"):README.index("## Design decisions")]
    named = set(re.findall(r"[\w/]*?(\w+\.py)\b", layout))
    folders = ("mavlink", "global_opt", "ao")  # listed as folders, their files in prose
    for package in ("uav_insar_planner", "uav_insar_sim"):
        for path in (REPO / package).rglob("*.py"):
            if path.parent.name in folders or path.name == "__main__.py" or (
                    path.name == "__init__.py" and path.parent.name != "solver"):
                continue
            assert path.name in named, f"{path.relative_to(REPO)} is not in the layout map"
    every = {p.name for p in REPO.glob("**/*.py") if ".venv" not in p.parts}
    assert named <= every, named - every
    for folder in ("solver/global_opt/", "solver/ao/", "mavlink/", "ros/"):
        assert folder in layout
