"""`uav-insar map` and where sweeps and maps solve (`--jobs`, `--scheduler`): the map's CSV,
plot and row order; one-line refusals (exit 2) before any solve; a run on worker processes or
on a Dask cluster gives the serial run's rows, float for float (the serial run's threads pinned
as the workers'); a scheduler that never answers is refused within its timeout, one without
workers is said at once; Ctrl-C is one line, exit 130, nothing written."""
from __future__ import annotations

import csv
import math
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import fields
from pathlib import Path

import process_group
import pytest
from test_bad_input_cli import assert_one_line, run

from uav_insar_planner.cli.checks import MAP_SOLVES_MAX
from uav_insar_planner.exit_codes import EXIT_INTERRUPTED
from uav_insar_planner.study.executors import (
    SCHEDULER_CONNECT_TIMEOUT_S,
    SCHEDULER_WORKERS_WAIT_S,
    jobs_max,
)
from uav_insar_planner.study.sweep import SweepRow
from uav_insar_planner.swarm import MAX_UAVS

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
    # the default columns: the Monte-Carlo ones and the worst case are opt-in (csv_fields)
    sweep_columns = [f.name for f in fields(SweepRow)
                     if not f.name.startswith("mc_") and f.name != "sigma_h_worst_m"]
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
                    f"index 0..{MAX_UAVS - 1}"),
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


# A map whose serial and parallel floats differed while only the workers pinned BLAS to one
# thread (issue 27: 6 of 8 rows differed in the last digits on this 2-core machine; a 1-core
# machine runs BLAS on one thread either way and cannot show it).
THREADED_MAP = ("map", "h_amb_min_m", "0.6", "1.6", "4", "rate_min_mbps[1]", "12", "14", "2",
                "--schemes", "proposed", "--set", "p_com_max_db=9", "--no-progress")


def test_jobs_1_and_jobs_2_agree_float_for_float(tmp_path: Path) -> None:
    rows = {}
    for jobs in ("1", "2"):
        path = tmp_path / f"jobs{jobs}.csv"
        proc = cli(*THREADED_MAP, "--jobs", jobs, "--csv", str(path))
        assert proc.returncode == 0, proc.stderr
        rows[jobs] = csv_rows(path)
    _same_rows(rows["1"], rows["2"])


def test_the_serial_run_pins_every_thread_pool_to_one_as_the_workers() -> None:
    import numpy as np
    from threadpoolctl import threadpool_info

    from uav_insar_planner.study.executors import WORKER_THREAD_ENV, serial

    np.ones((2, 2)) @ np.ones((2, 2))  # numpy's BLAS is loaded
    assert threadpool_info(), "no BLAS / OpenMP pool found to pin"
    before = _pools()
    with serial() as run:
        inside = run(_pools, [()])[0]
    # the pools and the variables a library loaded later reads, as in a worker
    assert inside == {"threads": {1}, "env": WORKER_THREAD_ENV}
    assert _pools() == before  # given back on leaving


def _pools() -> dict:
    from threadpoolctl import threadpool_info

    from uav_insar_planner.study.executors import WORKER_THREAD_ENV

    return {"threads": {p["num_threads"] for p in threadpool_info()},
            "env": {k: os.environ.get(k) for k in WORKER_THREAD_ENV}}


def _silent_port() -> tuple[socket.socket, int]:
    """A listening socket in this test's port range (31500-31999)."""
    for port in range(31500, 32000):
        s = socket.socket()
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            s.close()
            continue
        s.listen(16)
        return s, port
    raise RuntimeError("no free port in 31500-31999")


def test_a_port_that_accepts_and_never_answers_is_refused_within_the_timeout(
        capsys, tmp_path: Path) -> None:
    """Fault injected (a fake, not a scheduler): a TCP port that accepts every connection and
    never sends a byte, as a firewall's tarpit or a wrong service would. Dask's own client
    waits for its handshake for ever."""
    listener, port = _silent_port()
    accepted: list[socket.socket] = []

    def accept() -> None:
        while True:
            try:
                accepted.append(listener.accept()[0])
            except OSError:
                return

    threading.Thread(target=accept, daemon=True).start()
    address = f"tcp://127.0.0.1:{port}"
    t0 = time.monotonic()
    try:
        code, out, err = run(capsys, *SMALL_MAP, "--scheduler", address, "--no-progress",
                             "--csv", str(tmp_path / "m.csv"))
    finally:
        listener.close()
        for conn in accepted:
            conn.close()
    took = time.monotonic() - t0
    assert accepted, "the client never connected: the fake was not tried"
    assert_one_line(code, err, f"--scheduler: value '{address}' is not usable; no Dask "
                    f"scheduler answers at {address} within {SCHEDULER_CONNECT_TIMEOUT_S:g} s")
    assert took < SCHEDULER_CONNECT_TIMEOUT_S + 5, took
    assert out == "" and list(tmp_path.iterdir()) == []


def _read_until(proc: subprocess.Popen, wanted: Callable[[str], bool], timeout: float) -> str:
    """proc's stderr as it comes (a progress bar has no newline) until `wanted(text)`."""
    text, deadline = "", time.monotonic() + timeout
    fd = proc.stderr.fileno()
    os.set_blocking(fd, False)
    while not wanted(text) and time.monotonic() < deadline and proc.poll() is None:
        try:
            chunk = os.read(fd, 4096)
        except BlockingIOError:
            chunk = b""
        text += chunk.decode(errors="replace")
        if not chunk:
            time.sleep(0.05)
    return text


def _rest(proc: subprocess.Popen, timeout: float) -> str:
    proc.wait(timeout=timeout)
    os.set_blocking(proc.stderr.fileno(), True)
    return proc.stderr.read().decode(errors="replace")


def test_a_scheduler_without_workers_says_so_at_once_then_refuses(tmp_path: Path) -> None:
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=0, host="127.0.0.1", dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        with subprocess.Popen([*CLI, *SMALL_MAP, "--scheduler", address, "--csv",
                               str(tmp_path / "m.csv"), "--no-progress"], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, start_new_session=True) as proc:
            try:
                t0 = time.monotonic()
                said = _read_until(proc, lambda t: "\n" in t, 30)
                noticed = time.monotonic() - t0
                err = said + _rest(proc, SCHEDULER_WORKERS_WAIT_S + 30)
                took = time.monotonic() - t0
            finally:
                process_group.kill_group(proc)
    assert said.startswith(f"uav-insar map: the Dask scheduler at {address} has no workers; "
                           f"waiting up to {SCHEDULER_WORKERS_WAIT_S:g} s for one\n"), said
    assert noticed < 10, f"the notice came {noticed:.1f} s after the start"  # imports included
    assert took >= SCHEDULER_WORKERS_WAIT_S, took
    assert proc.returncode == 2, err
    lines = err.splitlines()
    assert len(lines) == 2 and "Traceback" not in err, err
    assert lines[1] == (f"uav-insar: error: --scheduler: value '{address}' is not usable; the "
                        f"Dask scheduler at {address} has no workers (waited "
                        f"{SCHEDULER_WORKERS_WAIT_S:g} s); start `dask worker {address} "
                        "--nthreads 1` on each machine")
    assert list(tmp_path.iterdir()) == []


def test_a_worker_that_joins_while_the_map_waits_gets_the_solves(tmp_path: Path) -> None:
    from dask.distributed import LocalCluster

    path = tmp_path / "m.csv"
    with LocalCluster(n_workers=0, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        with subprocess.Popen([*CLI, *SMALL_MAP, "--scheduler", cluster.scheduler_address,
                               "--csv", str(path), "--no-progress"], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, start_new_session=True) as proc:
            try:
                said = _read_until(proc, lambda t: "has no workers; waiting" in t, 30)
                assert "has no workers; waiting" in said, said
                cluster.scale(1)
                err = said + _rest(proc, 90)
            finally:
                process_group.kill_group(proc)
    assert proc.returncode == 0, err
    assert len(csv_rows(path)) == 18


BAR = re.compile(r"\d+/\d+ \[")  # tqdm's "n/total [elapsed<left, rate]"


@pytest.mark.parametrize("jobs", ["1", "2"], ids=["serial", "processes"])
def test_ctrl_c_mid_run_is_one_line_exit_130_and_nothing_written(tmp_path: Path,
                                                                 jobs: str) -> None:
    """Ctrl-C as a terminal sends it: SIGINT to the whole process group, workers included,
    once a few solves are done (the progress bar says so)."""
    # 3 600 solves: the warm chains made a 20 x 20 map finish in about a second, before the
    # Ctrl-C; this one runs for several.
    argv = ("map", "h_amb_min_m", "0.6", "1.6", "60", "rate_min_mbps[1]", "12", "18", "60",
            "--schemes", "proposed", "--set", "p_com_max_db=9", "--jobs", jobs,
            "--csv", str(tmp_path / "m.csv"), "--plot", str(tmp_path / "m.png"))
    with subprocess.Popen([*CLI, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          start_new_session=True) as proc:
        try:
            done = re.compile(r"\b([3-9]|\d\d+)/3600 \[")
            said = _read_until(proc, lambda t: bool(done.search(t)), 60)
            assert done.search(said) and proc.poll() is None, said
            process_group.kill_group(proc, signal.SIGINT)
            err = said + _rest(proc, 30)
            deadline = time.monotonic() + 10
            while _group_alive(proc.pid) and time.monotonic() < deadline:
                time.sleep(0.1)
            assert not _group_alive(proc.pid), "a worker outlived the interrupted map"
        finally:
            process_group.kill_group(proc)
    assert proc.returncode == EXIT_INTERRUPTED, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    said = [s for s in re.split(r"[\r\n]", err) if s.strip() and not BAR.search(s)]
    assert said == ["uav-insar map: interrupted (SIGINT) before it finished"], err
    assert list(tmp_path.iterdir()) == []


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


def test_an_output_file_is_written_whole_or_not_at_all(tmp_path: Path) -> None:
    from uav_insar_planner.cli.output import whole_file

    fresh, old = tmp_path / "new.csv", tmp_path / "old.csv"
    old.write_text("the previous map\n")
    for path in (fresh, old):
        with pytest.raises(KeyboardInterrupt), whole_file(path) as tmp:
            tmp.write_text("half a ma")
            raise KeyboardInterrupt  # Ctrl-C while writing
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.csv"]
    assert old.read_text() == "the previous map\n"
    with whole_file(fresh) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".csv" and not fresh.exists()
        tmp.write_text("a whole map\n")
    assert fresh.read_text() == "a whole map\n" and (fresh.stat().st_mode & 0o777) == (
        0o666 & ~_umask())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.csv", "old.csv"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
