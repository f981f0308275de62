"""Hostile and careless input to `uav-insar` and the params reader (bad values, files, paths
and command lines): every case is one line on stderr and exit 2, no traceback, refused before
any solve starts."""
from __future__ import annotations

import time
from pathlib import Path

import pytest

from uav_insar_planner import cli
from uav_insar_planner.cli.checks import SWEEP_COUNT_MAX
from uav_insar_planner.params import ParamError
from uav_insar_planner.params_file import load_params, parse_override

HUGE_INT = "9" * 5000  # beyond Python's 4300-digit int-str limit
LONG = "x" * 200_000


def run(capsys, *argv: str) -> tuple[int, str, str]:
    """cli.main in this process: (exit code, stdout, stderr); argparse's SystemExit too."""
    try:
        code = cli.main(list(argv))
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line(code: int, err: str, says: str, expected_code: int = 2) -> None:
    assert code == expected_code, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert len(err) < 400, f"{len(err)} characters"
    assert says in err, err


PARAMS_FILES = {
    "int key": ("planner:\n  ros__parameters:\n    1: 2\n", "line 3 (key 1 is not a name"),
    "null key": ("planner:\n  ros__parameters:\n    null: 2\n", "key null is not a name"),
    "bool key": ('"/**":\n  ros__parameters:\n    yes: 2\n', "key yes is not a name"),
    "int section": ("1:\n  ros__parameters:\n    z_max_m: 2.0\n", "line 1 (key 1 is not"),
    "5000 digits": (f'"/**":\n  ros__parameters:\n    num_slots: {HUGE_INT}\n',
                    "integer of 5000 digits"),
    "duplicate key": ('"/**":\n  ros__parameters:\n    z_max_m: 100.0\n    z_max_m: 90.0\n',
                      "line 4 (duplicate key 'z_max_m')"),
    "duplicate section": ('planner:\n  ros__parameters:\n    looks: 4\nplanner:\n'
                          '  ros__parameters:\n    looks: 5\n', "line 4 (duplicate key 'planner')"),
    "200 kB value": (f'"/**":\n  ros__parameters:\n    scheme: {LONG}\n',
                     "scheme: value 'xxxxxxxx"),
    "200 kB name": (f'"/**":\n  ros__parameters:\n    {LONG}: 1\n',
                    "is not valid YAML at line 3"),  # YAML keys stop at 1024 characters
    "int above float": ('"/**":\n  ros__parameters:\n    z_max_m: 1' + "0" * 18 + "\n",
                        "z_max_m: value 1000000000000000000 is not allowed"),
    "not UTF-8": (b'"/**":\n  ros__parameters:\n    scheme: "\xff"\n', "is not UTF-8"),
}


@pytest.mark.parametrize("case", sorted(PARAMS_FILES))
def test_bad_params_file_is_one_line(capsys, tmp_path: Path, case: str) -> None:
    text, says = PARAMS_FILES[case]
    path = tmp_path / "p.yaml"
    (path.write_bytes if isinstance(text, bytes) else path.write_text)(text)
    code, out, err = run(capsys, "solve", "--params", str(path))
    assert out == ""
    assert_one_line(code, err, says)


def test_dev_zero_is_refused_at_once(capsys) -> None:
    start = time.monotonic()
    code, out, err = run(capsys, "solve", "--params", "/dev/zero")
    assert_one_line(code, err, "larger than 1048576 bytes")
    assert time.monotonic() - start < 5


@pytest.mark.parametrize("setting, says", [
    (f"num_slots={HUGE_INT}", "num_slots: value '99999"),
    (f"scheme={LONG}", "scheme: value 'xxxx"),
    (f"{LONG}=1", "xxx...: unknown parameter"),
    ("1=2", "'1': unknown parameter"),
    ("a\nb=2", "'a\\nb': unknown parameter"),  # a name is shown on one line
    (LONG, "--set: value 'xxxxx"),
    ("z_max_m={a: 1, a: 2}", "z_max_m: value"),
])
def test_bad_set_is_one_line(capsys, setting: str, says: str) -> None:
    code, out, err = run(capsys, "solve", "--set", setting)
    assert_one_line(code, err, says)


def test_library_non_string_names_are_problems_not_crashes() -> None:
    with pytest.raises(ParamError) as err:
        load_params(None, {1: 2, None: 3, ("a",): 4})
    assert len(err.value.problems) == 3
    assert all("parameter name" in line for line in err.value.problems)
    assert parse_override(f"looks={HUGE_INT}")[1] == HUGE_INT  # a string, refused by the check


SLOW_SWEEP = ("sweep", "z_max_m", "50", "100", str(SWEEP_COUNT_MAX), "--no-progress")


@pytest.mark.parametrize("option, path, says", [
    ("--csv", "{tmp}/missing/s.csv", "cannot be written (No such file or directory)"),
    ("--csv", "{tmp}", "cannot be written (Is a directory)"),
    ("--csv", "/proc/s.csv", "cannot be written"),
    ("--csv", "/etc/hostname/s.csv", "cannot be written (Not a directory)"),
    ("--plot", "{tmp}/s.xyz", "expected a file name ending in one of .avif, .eps"),
    ("--plot", "{tmp}/s", "expected a file name ending in one of"),
    ("--plot", "{tmp}/missing/s.png", "cannot be written"),
])
def test_sweep_output_paths_checked_before_solving(capsys, tmp_path: Path, option: str,
                                                   path: str, says: str) -> None:
    start = time.monotonic()
    code, out, err = run(capsys, *SLOW_SWEEP, option, path.format(tmp=tmp_path))
    assert_one_line(code, err, says)
    assert time.monotonic() - start < 10, "a solve ran before the path was checked"
    assert out == "" and list(tmp_path.iterdir()) == []


def test_plot_formation_out_checked_before_solving(capsys, tmp_path: Path) -> None:
    code, out, err = run(capsys, "plot-formation", "--out", str(tmp_path / "f.docx"))
    assert_one_line(code, err, "--out: value")
    assert "expected a file name ending in one of" in err


def test_good_output_path_is_left_alone(capsys, tmp_path: Path) -> None:
    csv_path = tmp_path / "s.csv"
    code, out, err = run(capsys, "sweep", "z_max_m", "80", "100", "1", "--no-progress",
                         "--schemes", "proposed", "--csv", str(csv_path))
    assert code == 0, err
    assert csv_path.read_text().startswith("# sweep of z_max_m")


@pytest.mark.parametrize("start, stop, count, says", [
    ("50", "100", "0", "argument count: value '0' is not allowed; expected an integer in 1..10000"),
    ("50", "100", "-1", "argument count: value '-1'"),
    ("50", "100", str(SWEEP_COUNT_MAX + 1), "argument count: value '10001'"),
    ("50", "100", "2000000000", "argument count: value '2000000000'"),
    ("50", "100", HUGE_INT, "argument count: value '9999"),
    ("50", "100", "2.5", "argument count: value '2.5'"),
    ("nan", "100", "2", "argument start: value 'nan' is not allowed; expected a finite number"),
    ("50", "inf", "2", "argument stop: value 'inf'"),
    ("50", "1e309", "2", "argument stop: value '1e309'"),
    ("50", "1e7", "2", "z_max_m: value 10000000.0 is not allowed"),
])
def test_sweep_values_and_count_are_bounded(capsys, start: str, stop: str, count: str,
                                            says: str) -> None:
    t0 = time.monotonic()
    code, out, err = run(capsys, "sweep", "z_max_m", start, stop, count, "--no-progress")
    assert_one_line(code, err, says)
    assert time.monotonic() - t0 < 10


def test_unknown_long_option_is_cut(capsys) -> None:
    code, out, err = run(capsys, "solve", "--" + LONG)
    assert_one_line(code, err, "unrecognized arguments: --xxx")


def test_a_solver_exception_is_one_line_not_a_traceback(capsys, monkeypatch) -> None:
    """Fault injected (the one fake here): a back end that raises. The dispatcher names the
    back end and the exception in one line; the CLI exits 1, not 2 or 3 (neither bad input
    nor a verdict)."""
    from uav_insar_planner import solver

    def broken(params, scheme, objective):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(solver, "backend", lambda name: broken)
    with pytest.raises(solver.SolverFailure, match="solver global failed on scheme proposed"):
        solver.solve(load_params())
    code, out, err = run(capsys, "solve")
    assert_one_line(code, err, "ZeroDivisionError: float division by zero", expected_code=1)


def test_every_sweep_value_is_validated_before_the_first_solve(capsys) -> None:
    t0 = time.monotonic()
    code, out, err = run(capsys, "sweep", "num_slots", "10", "20", "4", "--no-progress")
    assert_one_line(code, err, "num_slots: value 13.333333333333334 is not allowed")
    assert out == "" and time.monotonic() - t0 < 10
