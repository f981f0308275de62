"""Dependencies point one way and each layer keeps to its job (checked on the source text)."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PLANNER = ROOT / "uav_insar_planner"
ROS_IMPORT = re.compile(r"^\s*(?:import|from)\s+(rclpy|\w+_msgs|std_srvs|rcl_interfaces)\b",
                        re.MULTILINE)
MAX_LINES = 400


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
    science = [PLANNER / f for f in ("params.py", "param_specs.py", "params_file.py",
                                     "model.py", "evaluate.py", "plan.py", "schemes.py",
                                     "multilook.py", "montecarlo.py", "replan.py", "scene.py")]
    science += sorted((PLANNER / "solver").rglob("*.py"))
    for path in science:
        text = path.read_text()
        assert not ROS_IMPORT.search(text), path
        assert not re.search(r"^\s*(?:import|from)\s+(pymavlink|uav_insar_planner\.(ros|"
                             r"mavlink))\b", text, re.MULTILINE), path


def test_no_product_file_over_400_lines():
    long = {str(p.relative_to(ROOT)): n for p in product_files()
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, long


def test_the_two_solver_back_ends_import_nothing_of_each_other():
    for own, other in (("ao", "global_opt"), ("global_opt", "ao")):
        for path in (PLANNER / "solver" / own).glob("*.py"):
            assert not re.search(rf"^\s*(?:import|from)\s+\S*solver(?:\.|\s+import\s+){other}\b",
                                 path.read_text(), re.MULTILINE), path
