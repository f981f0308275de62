"""Dependencies point one way and each layer keeps to its job (checked on the source text)."""
from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PLANNER = ROOT / "uav_insar_planner"
ROS_IMPORT = re.compile(r"^\s*(?:import|from)\s+(rclpy|\w+_msgs|std_srvs|rcl_interfaces)\b",
                        re.MULTILINE)
MAX_LINES = 380


def product_files() -> list[Path]:
    return sorted([*PLANNER.rglob("*.py"), *(ROOT / "uav_insar_sim").rglob("*.py")])


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
    science += sorted((PLANNER / "bag").rglob("*.py")) + sorted((PLANNER / "report").rglob("*.py"))
    for path in science:
        text = path.read_text()
        assert not ROS_IMPORT.search(text), path
        assert not re.search(r"^\s*(?:import|from)\s+(pymavlink|uav_insar_planner\.(ros|"
                             r"mavlink))\b", text, re.MULTILINE), path


def test_no_product_file_over_380_lines():
    long = {str(p.relative_to(ROOT)): n for p in product_files()
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, long


def test_the_two_solver_back_ends_import_nothing_of_each_other():
    for own, other in (("ao", "global_opt"), ("global_opt", "ao")):
        for path in (PLANNER / "solver" / own).glob("*.py"):
            assert not re.search(rf"^\s*(?:import|from)\s+\S*solver(?:\.|\s+import\s+){other}\b",
                                 path.read_text(), re.MULTILINE), path


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imported_modules(path: Path, known: set[str]) -> set[str]:
    """Product modules `path` imports anywhere (function bodies and TYPE_CHECKING included)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names = [f"{node.module}.{a.name}" for a in node.names] + [node.module]
        else:
            continue
        for name in names:
            while name and name not in known:
                name = name.rpartition(".")[0]
            if name:
                found.add(name)
    return found


def test_at_most_sixteen_modules_flat_in_the_planner_package():
    flat = sorted(p.name for p in PLANNER.glob("*.py"))
    assert len(flat) <= 16, flat


def test_no_import_circle_among_product_modules():
    files = {_module_name(p): p for p in product_files()}
    graph = {m: _imported_modules(p, set(files)) - {m} for m, p in files.items()}
    # An import of pkg.mod runs pkg/__init__ first; that edge is Python's, not ours.
    graph = {m: {d for d in deps if not m.startswith(d + ".")} for m, deps in graph.items()}
    done: set[str] = set()

    def visit(module: str, stack: list[str]) -> None:
        if module in stack:
            raise AssertionError("import circle: " + " -> ".join(
                stack[stack.index(module):] + [module]))
        if module in done:
            return
        for dep in sorted(graph.get(module, ())):
            visit(dep, [*stack, module])
        done.add(module)

    for module in sorted(graph):
        visit(module, [])


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
