"""The documentation says what the code does: the README is a short front page that gives the
two commands first; the site (mkdocs.yml, docs/) builds strictly, so no page links to a
missing page or anchor, and its reference pages, generated from the code at build time, list
every parameter of config/params.yaml; every file the pages name exists; the layout map
names every module."""
from __future__ import annotations

import os
import re
import sys
from pathlib import Path

import process_group
import pytest
import yaml

REPO = Path(__file__).resolve().parent.parent
README = (REPO / "README.md").read_text()
PAGES = sorted((REPO / "docs").rglob("*.md"))
MKDOCS = Path(sys.executable).with_name("mkdocs")


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The site, built as `make docs` builds it, strict (a warning is an error)."""
    out = tmp_path_factory.mktemp("site")
    if not MKDOCS.exists():
        pytest.fail("mkdocs is not installed beside this Python; run `make venv`")
    proc = process_group.run([str(MKDOCS), "build", "--strict", "-d", str(out)], cwd=REPO,
                          capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, NO_MKDOCS_2_WARNING="1"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "WARNING" not in proc.stderr, proc.stderr
    return out


def test_the_readme_is_a_front_page_with_the_two_commands_first():
    lines = README.splitlines()
    assert len(lines) <= 200, len(lines)
    first_block = README[README.index("```"):]
    first_block = first_block[:first_block.index("```", 3)]
    assert "make demo" in first_block and "make test" in first_block, first_block


def test_the_site_builds_strictly_with_every_page_in_the_nav(site: Path):
    nav = yaml.safe_load((REPO / "mkdocs.yml").read_text())["nav"]

    def pages(entries) -> list[str]:
        out = []
        for entry in entries:
            for value in entry.values():
                out += pages(value) if isinstance(value, list) else [value]
        return out

    in_nav = set(pages(nav))
    written = {str(p.relative_to(REPO / "docs")) for p in PAGES}
    assert written <= in_nav, written - in_nav  # no page left out of the nav
    for page in in_nav:
        assert (site / page.replace(".md", "").replace("index", "")).exists() or (
            site / page.replace(".md", ".html")).exists(), page


def test_the_reference_pages_hold_every_parameter_and_exit_code(site: Path):
    from uav_insar_planner.exit_codes import EXIT_CODES

    config = yaml.safe_load((REPO / "config" / "params.yaml").read_text())
    names = {name for section in config.values() for name in section["ros__parameters"]}
    html = (site / "reference" / "parameters" / "index.html").read_text()
    missing = sorted(n for n in names if f'id="{n}"' not in html)
    assert not missing, missing
    assert 'id="bridge-uav_id"' in html  # a name two nodes take: an anchor for each
    codes = (site / "reference" / "exit-codes" / "index.html").read_text()
    assert all(name in codes for name in ("EXIT_OK", "EXIT_CRASH", "EXIT_BAD_INPUT",
                                          "EXIT_INFEASIBLE", "EXIT_INTERRUPTED")), codes[:500]
    assert len(EXIT_CODES) == 5


def test_the_readme_links_only_to_pages_that_exist():
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README)
    assert links
    missing = [link for link in links if not (REPO / link).exists()]
    assert not missing, missing


def test_every_file_the_pages_name_exists():
    bases = (REPO, REPO / "uav_insar_planner", REPO / "uav_insar_planner" / "solver")
    for path in [REPO / "README.md", *PAGES]:
        text = path.read_text()
        named = set(re.findall(r"`((?:[\w-]+/)+[\w.-]+\.(?:py|yaml|md|xml|cfg|toml))`", text))
        named |= set(re.findall(r"`((?:test|benchmarks|config)/[\w.-]+)`", text))
        missing = [p for p in sorted(named) if not p.startswith("../")
                   and not any((base / p).exists() for base in bases)]
        assert not missing, (path.name, missing)
        assert "DESIGN.md" not in text, path.name


def test_the_layout_map_names_every_module():
    text = (REPO / "docs" / "layout.md").read_text()
    layout = text[:text.index("## Design decisions")]
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
