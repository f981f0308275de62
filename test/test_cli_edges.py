"""The command-line edges of the real `uav-insar` (its console script, as a user runs it): each
is one line on stderr and exit 2 before any work, with nothing written; the natural spellings
work; every verb answers --help."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import process_group
import pytest

from uav_insar_planner.cli import verbs
from uav_insar_planner.cli.montecarlo import MAX_DRAWS
from uav_insar_planner.cli.parser import split_ros_args
from uav_insar_planner.params import LENGTH_MAX_M, MULTILOOK_MAX_LOOKS

SCRIPT = Path(sys.executable).with_name("uav-insar")
CLI = [str(SCRIPT)] if SCRIPT.exists() else [sys.executable, "-m", "uav_insar_planner.cli"]
# A Monte-Carlo of these many samples takes seconds and prints its table before plotting: an
# empty stdout says none ran.
SLOW = ("--samples", "10000000")


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return process_group.run([*CLI, *args], capture_output=True, text=True, timeout=300, cwd=cwd)


def assert_refused(proc: subprocess.CompletedProcess, says: str) -> None:
    assert proc.returncode == 2, proc
    assert proc.stdout == "", proc.stdout
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert says in proc.stderr, proc.stderr


def test_every_verb_answers_help() -> None:
    proc = run("--help")
    assert proc.returncode == 0 and all(name in proc.stdout for name in verbs()), proc
    for name in verbs():
        proc = run(name, "--help")
        assert proc.returncode == 0 and proc.stdout.startswith(f"usage: uav-insar {name}"), proc


@pytest.mark.parametrize("verb, option", [
    (("montecarlo", *SLOW), "--plot"),
    (("sweep", "z_max_m", "80", "100", "2", "--no-progress"), "--plot"),
    (("plot-formation",), "--out"),
])
@pytest.mark.parametrize("path, says", [
    ("missing/x.png", "cannot be written (No such file or directory)"),
    ("x.qqq", "expected a file name ending in one of"),
    ("folder", "expected a file name ending in one of"),  # an existing folder
    ("noext", "expected a file name ending in one of"),   # would be noext.png
    ("dir.png", "cannot be written (Is a directory)"),    # a folder with an image's name
])
def test_image_paths_are_checked_before_any_work(tmp_path: Path, verb: tuple, option: str,
                                                 path: str, says: str) -> None:
    (tmp_path / "folder").mkdir()
    (tmp_path / "dir.png").mkdir()
    proc = run(*verb, option, path, cwd=tmp_path)
    assert_refused(proc, f"{option}: value '{path}' is not allowed")
    assert says in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.png", "folder"]


def test_negative_formation_in_its_natural_spelling() -> None:
    spaced = run("montecarlo", "--formation", "-27.118,47.118,-34.854,48.19", "--samples", "2000")
    joined = run("montecarlo", "--formation=-27.118,47.118,-34.854,48.19", "--samples", "2000")
    assert spaced.returncode == 0, spaced.stderr
    assert "given formation: U0 (-27.118, 47.118), U1 (-34.854, 48.190)" in spaced.stdout
    assert spaced.stdout == joined.stdout
    three = run("montecarlo", "--formation", "-27,47,-35,48,-36,49", "--samples", "2000")
    assert three.returncode == 0 and "U0-2" in three.stdout, three.stderr


@pytest.mark.parametrize("formation", ["1e12,47,-35,48", "-27,47,-35,1000001",
                                       "-27,47,-35,48,-36,-1e7"])
def test_formation_stops_at_the_length_limit(formation: str) -> None:
    proc = run("montecarlo", "--formation", formation)
    assert_refused(proc, f"--formation: value '{formation}' is not allowed")
    assert f"within +-{LENGTH_MAX_M:g} m" in proc.stderr


def test_looks_and_samples_are_bounded() -> None:
    for verb in (("solve",), ("montecarlo",)):
        proc = run(*verb, "--set", "looks=1000000")
        assert_refused(proc, f"looks: value 1000000 is not allowed; expected an integer in "
                       f"[1, {MULTILOOK_MAX_LOOKS}]")
    proc = run("montecarlo", "--set", f"looks={MULTILOOK_MAX_LOOKS}", *SLOW)
    assert_refused(proc, f"--samples: value '10000000' is not allowed; expected an integer in "
                   f"[2, {MAX_DRAWS // MULTILOOK_MAX_LOOKS}]")
    proc = run("sweep", "looks", "4", str(MULTILOOK_MAX_LOOKS), "2", "--montecarlo",
               "--mc-samples", "10000000", "--no-progress")
    assert_refused(proc, "--mc-samples: value '10000000' is not allowed")
    proc = run("montecarlo", "--samples", "100000000")
    assert_refused(proc, "--samples: value '100000000' is not allowed; expected an integer in "
                   "[2, 10000000]")


def test_a_negative_number_with_an_exponent_is_a_value_not_an_option() -> None:
    proc = run("solve", "--min-separation-m", "-1e3")
    assert_refused(proc, "--min-separation-m: value -1000.0 is not allowed")


def _bag(tmp_path: Path, case: str) -> Path:
    bag = tmp_path / "bag"
    if case == "a file":
        bag.write_text("not a bag\n")
    elif case == "empty folder":
        bag.mkdir()
    elif case == "garbage metadata":
        bag.mkdir()
        (bag / "metadata.yaml").write_text("junk\n")
    elif case in ("truncated mcap", "no storage file"):
        from test_bag_report import write_known_bag

        write_known_bag(bag)
        mcap = next(bag.glob("*.mcap"))
        if case == "no storage file":
            mcap.unlink()
        else:
            mcap.write_bytes(mcap.read_bytes()[:200])
    return bag


@pytest.mark.parametrize("case, says", [
    ("missing", "does not exist"), ("a file", "is not a folder"),
    ("empty folder", "has no metadata.yaml"), ("garbage metadata", "cannot be read"),
    ("truncated mcap", "cannot be read"), ("no storage file", "cannot be read"),
])
def test_report_refuses_a_bad_bag_before_any_progress_bar(tmp_path: Path, case: str,
                                                          says: str) -> None:
    bag = _bag(tmp_path, case)
    before = sorted(p.name for p in tmp_path.iterdir())
    proc = run("report", str(bag))  # with its progress bar on
    assert_refused(proc, f"uav-insar report: error: BAG: '{bag}' {says}")
    assert "reading" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize("out, says", [("/proc/x/report", "'/proc' cannot be written"),
                                       ("{tmp}/file/report", "is not a folder"),
                                       ("{tmp}/file", "it exists and is not a folder")])
def test_report_checks_its_out_folder_before_reading(tmp_path: Path, out: str,
                                                     says: str) -> None:
    from test_bag_report import write_known_bag

    write_known_bag(tmp_path / "bag")
    (tmp_path / "file").write_text("x")
    proc = run("report", str(tmp_path / "bag"), "--out", out.format(tmp=tmp_path))
    assert_refused(proc, "--out: value")
    assert says in proc.stderr and "reading" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag", "file"]


def test_ros_arguments_are_split_by_rcl_rule() -> None:
    own, ros = split_ros_args(["/x", "--ros-args", "-r", "__ns:=/uav1", "--", "--once",
                               "--ros-args", "--log-level", "warn"])
    assert own == ["/x", "--once"]
    assert ros == ["--ros-args", "-r", "__ns:=/uav1", "--", "--ros-args", "--log-level", "warn"]


def test_the_vehicle_usage_error_is_one_line() -> None:
    proc = process_group.run([sys.executable, "-m", "uav_insar_sim.vehicle", "--sysid", "two",
                           "--listen", "udpin:127.0.0.1:0"], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr == ("uav-insar-vehicle: error: argument --sysid: invalid int value: "
                           "'two'\n")


@pytest.mark.parametrize("verb", [("echo", "/chatter", "--timeout", "5"),
                                  ("record", "{tmp}/bag", "--duration", "5")])
def test_bad_ros_arguments_are_one_line_before_rcl_starts(tmp_path: Path, verb: tuple) -> None:
    """rclpy.init would log an `[ERROR] [rcl]` line of its own first."""
    args = [a.format(tmp=tmp_path) for a in verb]
    proc = run(*args, "--ros-args", "--log-level", "nonsense")
    assert_refused(proc, f"uav-insar {verb[0]}: error: bad ROS arguments: Failed to parse ROS "
                   "arguments: Couldn't parse log level")
    assert list(tmp_path.iterdir()) == []


def test_a_reader_that_stops_early_gets_no_traceback() -> None:
    # `uav-insar solve --json | head -1`: the pipe closes after the first line
    proc = subprocess.Popen([*CLI, "solve", "--json"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        assert proc.stdout.readline().strip() == "{"
        proc.stdout.close()
        err = proc.stderr.read()
        assert proc.wait(timeout=60) == 0, err
    finally:
        process_group.kill_group(proc)
    assert "Traceback" not in err and "BrokenPipe" not in err, err
