"""Benchmark of where the sweeps solve: serial vs worker processes, side by side in one run.

Runs the same study with --jobs 1 (this process, one solve after the other), then on 2, 3,
... worker processes up to the cores (study/executors.process_pool, BLAS/OpenMP pinned to one
thread per worker), and once more on all cores with the threads not pinned, interleaved over
`--repeats` rounds. The study is the paper's Figures 3 and 4 (16 + 21 values, four schemes:
148 solves; parameters as benchmarks/global_solver.py), or with `--map N` an N x N map of
h_amb_min_m 0.5..2.0 and rate_min_mbps[1] 10..20 for the four schemes. Prints each run's
median wall time (pool start-up included), the speed-up over serial, and whether every row
equals the serial run's (solve times aside).

Run: .venv/bin/python benchmarks/sweep_jobs.py [--repeats 3] [--map 12]
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from uav_insar_planner.params import SCHEMES, default_params
from uav_insar_planner.study.executors import process_pool, serial
from uav_insar_planner.study.grid import map_params, run_map
from uav_insar_planner.study.sweep import run_sweep

FIGURES = [("h_amb_min_m", np.linspace(0.5, 2.0, 16),
            {"master_fixed_xz_m": [-54.0, 74.0], "p_com_max_db": 10.1}),
           ("rate_min_mbps[1]", np.linspace(10.0, 20.0, 21),
            {"master_fixed_xz_m": [-41.0, 61.0], "p_com_max_db": 9.0})]


def figures(run) -> list:
    rows = []
    for name, values, overrides in FIGURES:
        rows += run_sweep(default_params().replace(**overrides), name, values, SCHEMES, run=run)
    return rows


def grid(n: int):
    cells = map_params(default_params().replace(master_fixed_xz_m=[-54.0, 74.0]),
                       "h_amb_min_m", np.linspace(0.5, 2.0, n), "rate_min_mbps[1]",
                       np.linspace(10.0, 20.0, n))
    return lambda run: [r.point for r in run_map(cells, SCHEMES, run=run)]


def timed(study, jobs: int, pin: bool) -> tuple[float, list]:
    start = time.perf_counter()
    if jobs == 1:  # pinned to one thread as the workers (executors.serial), as --jobs 1 is
        with serial() as run:
            rows = study(run)
    else:
        with process_pool(jobs, pin_threads=pin) as run:
            rows = study(run)
    return time.perf_counter() - start, rows


def key(row) -> list:
    return [repr(v) for k, v in vars(row).items() if k != "solve_time_s"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--map", type=int, default=0, metavar="N",
                        help="an N x N map instead of the figures")
    args = parser.parse_args()
    cores = os.cpu_count() or 1
    study = grid(args.map) if args.map else figures
    runs = [(j, True) for j in range(1, cores + 1)] + [(cores, False)]
    times: dict = {r: [] for r in runs}
    reference, same = None, {r: True for r in runs}
    for _ in range(args.repeats):
        for jobs, pin in runs:
            t, rows = timed(study, jobs, pin)
            times[(jobs, pin)].append(t)
            reference = reference or [key(r) for r in rows]
            same[(jobs, pin)] &= [key(r) for r in rows] == reference
    what = f"{args.map} x {args.map} map" if args.map else "Figures 3 + 4"
    print(f"{what}: {len(reference)} solves, {cores} cores, median of {args.repeats}, "
          f"load average {os.getloadavg()[0]:.2f}")
    serial = statistics.median(times[(1, True)])
    for (jobs, pin), ts in times.items():
        med = statistics.median(ts)
        label = "--jobs 1 (serial)" if jobs == 1 else f"--jobs {jobs}" + (
            "" if pin else " (threads not pinned)")
        print(f"  {label:<32} {med:7.2f} s  speed-up {serial / med:4.2f}x  "
              f"rows identical to serial: {'yes' if same[(jobs, pin)] else 'NO'}")


if __name__ == "__main__":  # the workers' fork server imports this file
    main()
