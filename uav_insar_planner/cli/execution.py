"""Where the solves of `uav-insar sweep` and `map` run (`--jobs`, `--scheduler`) and their
progress bar (`--no-progress`); the runners are study/executors.py's. `--jobs 1` is the
serial run with its threads pinned as the workers' are (executors.serial), so every way of
running gives the same floats."""
from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager

from uav_insar_planner.cli import PROG
from uav_insar_planner.cli.checks import jobs_count, scheduler_address
from uav_insar_planner.cli.parser import one_line
from uav_insar_planner.params import ParamError
from uav_insar_planner.study.executors import (
    Runner,
    SchedulerUnavailable,
    dask_scheduler,
    process_pool,
    serial,
)


def add_execution_arguments(parser: argparse.ArgumentParser) -> None:
    """Add `--jobs`, `--scheduler` (one or the other) and `--no-progress` to `parser`."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--jobs", type=jobs_count, metavar="N",
                       help="solve on N worker processes of this machine (default: one per "
                       "core; 1: one after the other in this process)")
    where.add_argument("--scheduler", type=scheduler_address, metavar="ADDRESS",
                       help="solve on the workers of the Dask scheduler at ADDRESS, e.g. "
                       "tcp://10.0.0.5:8786 (needs the `cluster` extra)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")


@contextmanager
def solving(args: argparse.Namespace, solves: int) -> Iterator[tuple[Runner, object]]:
    """(runner, tqdm bar) for `solves` solves: the runner the options ask for, its pool or
    cluster client opened first (ParamError, one line, when the scheduler is unavailable) and
    closed on leaving, whatever happens."""
    from tqdm import tqdm

    with ExitStack() as stack:
        if args.scheduler:
            try:
                run = stack.enter_context(dask_scheduler(args.scheduler, say=_say(args)))
            except SchedulerUnavailable as exc:
                raise ParamError([f"--scheduler: value {args.scheduler!r} is not usable; "
                                  f"{exc}"]) from None
        else:
            jobs = min(args.jobs or os.cpu_count() or 1, solves)
            run = stack.enter_context(process_pool(jobs) if jobs > 1 else serial())
        bar = stack.enter_context(tqdm(total=solves, unit="solve", file=sys.stderr,
                                       disable=args.no_progress))
        yield run, bar


def _say(args: argparse.Namespace):
    """One line on stderr, after the verb's name, as the errors are."""
    return lambda line: print(one_line(f"{PROG} {args.verb}: {line}"), file=sys.stderr,
                              flush=True)
