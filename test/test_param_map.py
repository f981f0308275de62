"""`uav-insar map` and where sweeps and maps solve (`--jobs`, `--scheduler`): the map's CSV,
plot and row order; one-line refusals (exit 2) before any solve; a run on worker processes or
on a Dask cluster gives the serial run's rows, float for float."""
from __future__ import annotations

import csv
import math
import socket
import subprocess
import sys
import time
from dataclasses import fields
from pathlib import Path

import process_group
import pytest
from test_bad_input_cli import assert_one_line, run

from uav_insar_planner.cli.checks import MAP_SOLVES_MAX
from uav_insar_planner.study.executors import jobs_max
from uav_insar_planner.sweep import SweepRow

CLI = [sys.executable, "-m", "uav_insar_planner.cli"]
# 3 x 3 cells, two schemes; static-power is feasible at rate 17 Mbit/s and not at 18 with
# P_com,max 9 dB (test_cli.py's sweep), so the map has both kinds of cell.
SMALL_MAP = ("map", "h_amb_min_m", "0.9", "1.1", "3", "rate_min_mbps[1]", "17", "18", "3",
             "--schemes", "proposed", "static-power", "--set", "p_com_max_db=9",
             "--set", "rate_margin=0")  # Figure 4's map, on the paper's C10
SMALL_SWEEP = ("sweep", "h_amb_min_m", "0.9", "1.2", "3", "--schemes", "proposed",
               "fixed-master", "--set", "master_fixed_xz_m=[-54,74]")


def cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """`uav-insar ARGS` in its own process group, stopped by it (workers too) if it hangs."""
    return process_group.run([*CLI, *args], capture_output=True, text=True, timeout=timeout)


def csv_rows(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(line for line in path.read_text().splitlines()
                               if not line.startswith("#")))


@pytest.fixture(scope="module")
def dask_address():
    """A Dask scheduler and two one-thread worker processes on loopback, closed after."""
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def test_map_writes_one_row_per_cell_and_scheme_and_a_heat_map(tmp_path: Path) -> None:
    csv_path, png = tmp_path / "m.csv", tmp_path / "m.png"
    proc = cli(*SMALL_MAP, "--jobs", "2", "--csv", str(csv_path), "--plot", str(png),
               "--no-progress")
    assert proc.returncode == 0, proc.stderr
    rows = csv_rows(csv_path)
    sweep_columns = [f.name for f in fields(SweepRow) if not f.name.startswith("mc_")]
    assert list(rows[0]) == ["value1", "value2", *sweep_columns[1:]]
    order = [(float(r["value1"]), float(r["value2"]), r["scheme"]) for r in rows]
    assert order == [(v1, v2, s) for v1 in (0.9, 1.0, 1.1) for v2 in (17.0, 17.5, 18.0)
                     for s in ("proposed", "static-power")]
    static = {(float(r["value1"]), float(r["value2"])): r["feasible"] == "True"
              for r in rows if r["scheme"] == "static-power"}
    assert static[(0.9, 17.0)] and not static[(0.9, 18.0)]
    assert all(r["feasible"] == "True" for r in rows if r["scheme"] == "proposed")
    assert all(float(r["sigma_h_m"]) > 0 for r in rows if r["feasible"] == "True")
    n_ok = sum(static.values())
    assert f"static-power     {n_ok}/9 cells feasible" in proc.stdout
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _same_rows(a: list[dict[str, str]], b: list[dict[str, str]]) -> None:
    """Every field equal, floats with == (NaN where both are NaN); the wall-clock solve time
    is the one column that differs between any two runs, serial ones too."""
    assert len(a) == len(b) and a
    for ra, rb in zip(a, b, strict=True):
        assert list(ra) == list(rb)
        for key in ra:
            if key == "solve_time_s":
                continue
            try:
                fa, fb = float(ra[key]), float(rb[key])
            except ValueError:
                assert ra[key] == rb[key], key
                continue
            assert fa == fb or (math.isnan(fa) and math.isnan(fb)), (key, ra, rb)


@pytest.mark.parametrize("study", [SMALL_MAP, SMALL_SWEEP], ids=["map", "sweep"])
def test_processes_and_dask_give_the_serial_rows(tmp_path: Path, dask_address: str,
                                                 study: tuple[str, ...]) -> None:
    runs = {"serial": ("--jobs", "1"), "processes": ("--jobs", "2"),
            "dask": ("--scheduler", dask_address)}
    rows = {}
    for name, where in runs.items():
        path = tmp_path / f"{name}.csv"
        proc = cli(*study, *where, "--csv", str(path))
        assert proc.returncode == 0, proc.stderr
        rows[name] = csv_rows(path)
        total = len(rows[name])
        # the bar advances as the results arrive, to the total
        assert f"{total}/{total}" in proc.stderr and "solve/s" in proc.stderr, proc.stderr
    _same_rows(rows["serial"], rows["processes"])
    _same_rows(rows["serial"], rows["dask"])


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


BAD_MAP = {
    "name1": (("map", "nope", "1", "2", "2", "z_max_m", "80", "90", "2"),
              "map NAME1: value 'nope' is not allowed; expected a numeric parameter"),
    "name2 index": (("map", "z_max_m", "80", "90", "2", "rate_min_mbps", "1", "2", "2"),
                    "map NAME2: value 'rate_min_mbps' is not allowed; rate_min_mbps needs an "
                    "index 0..5"),
    "same name": (("map", "z_max_m", "80", "90", "2", "z_max_m", "80", "90", "2"),
                  "map NAME2: value 'z_max_m' is not allowed; expected a parameter other"),
    "count1": (("map", "z_max_m", "80", "90", "0", "h_amb_min_m", "1", "2", "2"),
               "argument count1: value '0' is not allowed; expected an integer in 1..10000"),
    "count2": (("map", "z_max_m", "80", "90", "2", "h_amb_min_m", "1", "2", "10001"),
               "argument count2: value '10001'"),
    "start2": (("map", "z_max_m", "80", "90", "2", "h_amb_min_m", "nan", "2", "2"),
               "argument start2: value 'nan' is not allowed; expected a finite number"),
    "value": (("map", "z_max_m", "80", "1e7", "2", "h_amb_min_m", "1", "2", "2"),
              "z_max_m: value 10000000.0 is not allowed"),
    "total": (("map", "z_max_m", "50", "100", "201", "h_amb_min_m", "1", "2", "200",
               "--schemes", "proposed"),
              f"200 x 1 = 40200 solves is not allowed; expected at most {MAP_SOLVES_MAX}"),
    "total, four schemes": (("map", "z_max_m", "50", "100", "100", "h_amb_min_m", "1", "2",
                             "101"), "100 x 101 x 4 = 40400 solves"),
}


@pytest.mark.parametrize("case", sorted(BAD_MAP))
def test_bad_map_input_is_one_line_before_any_solve(capsys, tmp_path: Path, case: str) -> None:
    argv, says = BAD_MAP[case]
    t0 = time.monotonic()
    code, out, err = run(capsys, *argv, "--no-progress", "--csv", str(tmp_path / "m.csv"))
    assert_one_line(code, err, says)
    assert out == "" and list(tmp_path.iterdir()) == []
    assert time.monotonic() - t0 < 10, "a solve ran before the input was checked"


BAD_WHERE = {
    "jobs 0": (("--jobs", "0"), f"argument --jobs: value '0' is not allowed; expected an "
               f"integer in 1..{jobs_max()}"),
    "jobs -1": (("--jobs", "-1"), "argument --jobs: value '-1'"),
    "jobs 10000": (("--jobs", "10000"), "argument --jobs: value '10000'"),
    "jobs two": (("--jobs", "two"), "argument --jobs: value 'two'"),
    "no scheme": (("--scheduler", "127.0.0.1:8786"), "argument --scheduler: value "
                  "'127.0.0.1:8786' is not allowed; expected SCHEME://HOST:PORT"),
    "http": (("--scheduler", "http://127.0.0.1:8786"), "argument --scheduler: value 'http:"),
    "no port": (("--scheduler", "tcp://127.0.0.1"), "argument --scheduler: value 'tcp:"),
    "port 99999": (("--scheduler", "tcp://127.0.0.1:99999"), "argument --scheduler: value"),
    "both": (("--jobs", "2", "--scheduler", "tcp://127.0.0.1:8786"),
             "argument --scheduler: not allowed with argument --jobs"),
}


@pytest.mark.parametrize("verb", [SMALL_MAP, SMALL_SWEEP], ids=["map", "sweep"])
@pytest.mark.parametrize("case", sorted(BAD_WHERE))
def test_bad_jobs_or_scheduler_is_one_line(capsys, tmp_path: Path, verb: tuple[str, ...],
                                           case: str) -> None:
    where, says = BAD_WHERE[case]
    code, out, err = run(capsys, *verb, *where, "--csv", str(tmp_path / "m.csv"))
    assert_one_line(code, err, says)
    assert out == "" and list(tmp_path.iterdir()) == []


def test_a_scheduler_that_does_not_answer_is_refused_before_any_solve(capsys,
                                                                      tmp_path: Path) -> None:
    address = f"tcp://127.0.0.1:{_free_port()}"
    code, out, err = run(capsys, *SMALL_MAP, "--scheduler", address, "--no-progress",
                         "--csv", str(tmp_path / "m.csv"))
    assert_one_line(code, err, f"--scheduler: value '{address}' is not usable; no Dask "
                    f"scheduler answers at {address} within 5 s")
    assert out == "" and list(tmp_path.iterdir()) == []


def test_without_dask_scheduler_is_one_line(capsys, monkeypatch, tmp_path: Path) -> None:
    """Fault injected (the one fake here): dask.distributed made unimportable, as on an
    install without the `cluster` extra."""
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    code, out, err = run(capsys, *SMALL_SWEEP, "--scheduler", "tcp://127.0.0.1:8786",
                         "--csv", str(tmp_path / "s.csv"))
    assert_one_line(code, err, "needs dask.distributed, which is not installed here")
    assert "pip install 'uav_insar_planner[cluster]'" in err
    assert out == "" and list(tmp_path.iterdir()) == []
