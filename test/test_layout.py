"""Dependencies point one way and each layer keeps to its job (checked on the source text)."""
from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "docs" / "_hooks"))  # as MkDocs loads the hooks: their folder

from reference_layout import find_circle, folder_graph, module_graph, product_files  # noqa: E402

PLANNER = ROOT / "uav_insar_planner"
ROS_IMPORT = re.compile(r"^\s*(?:import|from)\s+(rclpy|\w+_msgs|std_srvs|rcl_interfaces)\b",
                        re.MULTILINE)
MAX_LINES = 380


def test_only_the_ros_folder_imports_ros():
    offenders = [str(p.relative_to(ROOT)) for p in PLANNER.rglob("*.py")
                 if "ros" not in p.relative_to(PLANNER).parts[:1]
                 and ROS_IMPORT.search(p.read_text())]
    assert not offenders, offenders


def test_the_planner_package_never_imports_the_simulator():
    offenders = [str(p.relative_to(ROOT)) for p in PLANNER.rglob("*.py")
                 if re.search(r"^\s*(?:import|from)\s+uav_insar_sim\b", p.read_text(),
                              re.MULTILINE)]
    assert not offenders, offenders


def test_the_science_imports_nothing_of_ros_or_mavlink():
    """Every module flat at the top of the package is the science (or a convention of the
    whole suite: swarm.py, exit_codes.py) and imports nothing of ROS or MAVLink."""
    science = sorted(PLANNER.glob("*.py")) + sorted((PLANNER / "solver").rglob("*.py"))
    for folder in ("bag", "report", "study", "replanning", "param_specs", "survey",
                   "tomography"):
        science += sorted((PLANNER / folder).rglob("*.py"))
    for path in science:
        text = path.read_text()
        assert not ROS_IMPORT.search(text), path
        assert not re.search(r"^\s*(?:import|from)\s+(pymavlink|uav_insar_planner\.(ros|"
                             r"mavlink))\b", text, re.MULTILINE), path


def test_the_layers_below_the_survey_never_import_it():
    """survey/ lays passes out of the track and mission-file layers; the model, the solvers,
    the track, the MAVLink bridge and the simulator know nothing of surveys."""
    below = [PLANNER / "model.py", *(PLANNER / "solver").rglob("*.py"),
             *(PLANNER / "track").rglob("*.py"), *(PLANNER / "mavlink").rglob("*.py"),
             *(ROOT / "uav_insar_sim").rglob("*.py")]
    offenders = [str(p.relative_to(ROOT)) for p in below if re.search(
        r"^\s*(?:import|from)\s+uav_insar_planner(?:\.survey\b|\s+import\s+survey\b)",
        p.read_text(), re.MULTILINE)]
    assert len(below) > 20 and not offenders, offenders


def test_no_product_file_over_380_lines():
    long = {str(p.relative_to(ROOT)): n for p in product_files()
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, long


def test_the_two_solver_back_ends_import_nothing_of_each_other():
    for own, other in (("ao", "global_opt"), ("global_opt", "ao")):
        for path in (PLANNER / "solver" / own).glob("*.py"):
            assert not re.search(rf"^\s*(?:import|from)\s+\S*solver(?:\.|\s+import\s+){other}\b",
                                 path.read_text(), re.MULTILINE), path


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def test_no_product_file_reaches_into_another_modules_private_names():
    """Modules meet at public names with a documented contract (e.g. the global back end's
    kernel, solver/global_opt/kernel.py), never at a sibling's `_name`: neither imported
    (`from m import _f`) nor reached through the module (`m._f`)."""
    offenders = []
    for path in product_files():
        tree = ast.parse(path.read_text())
        modules = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                modules |= {a.asname or a.name.split(".")[0] for a in node.names
                            if a.name.startswith("uav_insar")}
            elif (isinstance(node, ast.ImportFrom) and node.module
                  and node.module.startswith("uav_insar")):
                modules |= {a.asname or a.name for a in node.names}
                offenders += [f"{path.relative_to(ROOT)}:{node.lineno}: {node.module}.{a.name}"
                              for a in node.names if _private(a.name)]
        offenders += [f"{path.relative_to(ROOT)}:{node.lineno}: {node.value.id}.{node.attr}"
                      for node in ast.walk(tree) if isinstance(node, ast.Attribute)
                      and _private(node.attr) and isinstance(node.value, ast.Name)
                      and node.value.id in modules]
    assert not offenders, offenders


def test_no_product_line_branches_on_a_solver_back_ends_name():
    """Each back end is declared once (param_specs.science.BACKENDS) and the dispatcher, the
    objective rule and the docs read the declaration: no code compares a value with a back
    end's name."""
    from uav_insar_planner.param_specs.science import SOLVERS

    offenders = [f"{path.relative_to(ROOT)}:{node.lineno}" for path in product_files()
                 for node in ast.walk(ast.parse(path.read_text())) if isinstance(node, ast.Compare)
                 and any(isinstance(c, ast.Constant) and c.value in SOLVERS
                         for c in [node.left, *node.comparators])]
    assert not offenders, offenders


def test_at_most_sixteen_modules_flat_in_the_planner_package():
    flat = sorted(p.name for p in PLANNER.glob("*.py"))
    assert len(flat) <= 16, flat


def test_no_import_circle_among_product_modules():
    circle = find_circle(module_graph())
    assert not circle, "import circle: " + " -> ".join(circle or ())


def test_no_folder_imports_a_folder_that_imports_it_back():
    """Directly or through others (docs/_hooks/reference_layout.py draws the same graph on the
    layout page, floor by floor)."""
    graph = folder_graph()
    assert {"uav_insar_planner/swarm.py", "uav_insar_planner/solver/ao/", "uav_insar_sim/vehicle/",
            "uav_insar_planner/cli/__init__.py"} <= set(graph)  # the nodes it should have
    assert "uav_insar_planner/solver/" in graph["uav_insar_planner/study/"]
    circle = find_circle(graph)
    assert not circle, "folder import circle: " + " -> ".join(circle or ())


def test_a_circle_between_folders_is_found():
    """The check itself: a circle through a third folder, and its first node repeated."""
    graph = {"a/": {"b/"}, "b/": {"c/"}, "c/": {"a/"}, "d/": {"a/"}}
    assert find_circle(graph) == ["a/", "b/", "c/", "a/"]
    assert find_circle({"a/": {"b/"}, "b/": set()}) is None


def test_one_argument_parser_class():
    classes = [f"{p.relative_to(ROOT)}:{n.name}" for p in product_files()
               for n in ast.walk(ast.parse(p.read_text())) if isinstance(n, ast.ClassDef)
               and any("ArgumentParser" in ast.unparse(b) for b in n.bases)]
    assert len(classes) == 1, classes


def test_no_function_over_80_lines():
    long = [f"{p.relative_to(ROOT)}:{n.name} ({n.end_lineno - n.lineno + 1} lines)"
            for p in product_files() for n in ast.walk(ast.parse(p.read_text()))
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
            and n.end_lineno - n.lineno + 1 > 80]
    assert not long, long


# Spellings of "three UAVs" in code: loops, array shapes, name lists, per-UAV choices (a list
# parameter of length 3 is an N/E/D vector as often as a per-UAV list: not flagged here).
UAV_COUNT_LITERAL = re.compile(
    r"range\(\s*(?:1\s*,\s*)?3\s*\)|\(\s*3\s*,\s*(?:2|3|N|-1|p\.num_slots|params\.num_slots)"
    r"\s*\)|\(\s*3\s*,\s*(?=p\.|params\.)|\(0, 1, 2\)|\[0, 1, 2\]|\"uav2\"|'uav2'")


def test_no_literal_uav_count_outside_its_home():
    home = PLANNER / "swarm.py"
    offenders = []
    for path in product_files():
        if path == home:
            continue
        tree = ast.parse(path.read_text())
        strings = {i for n in ast.walk(tree)  # docstrings and other prose
                   if isinstance(n, ast.Constant) and isinstance(n.value, str)
                   for i in range(n.lineno, n.end_lineno + 1)}
        for i, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#")[0]
            if i not in strings and UAV_COUNT_LITERAL.search(code):
                offenders.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()}")
    assert not offenders, offenders


def test_only_the_profile_tables_branch_on_the_autopilot_flavour():
    """What differs per autopilot is a row of autopilots/profiles.py (the bridge's) or of
    uav_insar_sim/vehicle/profiles.py (the simulator's): nowhere else is a flavour's name
    compared with, a table keyed by it, or an `is it PX4` flag read."""
    from uav_insar_planner.autopilots.profiles import AUTOPILOTS

    homes = {PLANNER / "autopilots" / "profiles.py",
             ROOT / "uav_insar_sim" / "vehicle" / "profiles.py"}
    names = set(AUTOPILOTS)

    def flavours(node: ast.AST) -> bool:
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            return any(flavours(e) for e in node.elts)
        return isinstance(node, ast.Constant) and node.value in names

    offenders = []
    for path in product_files():
        if path in homes:
            continue
        for n in ast.walk(ast.parse(path.read_text())):
            compared = isinstance(n, ast.Compare) and any(
                flavours(e) for e in (n.left, *n.comparators))
            keyed = isinstance(n, ast.Dict) and any(k is not None and flavours(k)
                                                    for k in n.keys)
            flag = isinstance(n, (ast.Attribute, ast.Name)) and \
                getattr(n, "attr", getattr(n, "id", "")) in names
            if compared or keyed or flag:
                offenders.append(f"{path.relative_to(ROOT)}:{n.lineno}: {ast.unparse(n)[:60]}")
    assert not offenders, offenders
