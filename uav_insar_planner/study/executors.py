"""Run independent tasks `fn(*args)` serially, in a process pool or on a Dask cluster.

The one home of the parallel execution of sweeps and maps. A runner is called as
`run(fn, tasks, progress)` and returns `[fn(*t) for t in tasks]`: in the order of the tasks
whatever order they finish in, so a parallel run gives the serial run's rows value for value
(each solve is deterministic and sees the same inputs). `progress()` is called once per
finished task, as it arrives. `fn` must be a module-level function (pickled by reference).

Threads: a worker solves one problem at a time. Its BLAS / OpenMP pools are pinned to one
thread (WORKER_THREAD_ENV, set while the pool's processes start) so that N workers use N cores,
not N times the cores; Dask's nanny does the same for its workers by default. Workers start
from a fork server, not by forking this process: a fork of a process with threads (tqdm's
monitor, OpenBLAS's pool) can deadlock, and Python 3.12 warns of it.
"""
from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from contextlib import contextmanager
from typing import Any, Protocol

WORKER_THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                     "MKL_NUM_THREADS": "1"}
JOBS_PER_CORE_MAX = 4  # --jobs at most this many per core: the solves are CPU-bound
SCHEDULER_CONNECT_TIMEOUT_S = 5.0  # a Dask scheduler that does not answer within this is an error


class Runner(Protocol):
    def __call__(self, fn: Callable[..., Any], tasks: Sequence[tuple],
                 progress: Callable[[], Any] | None = None) -> list: ...


def jobs_max() -> int:
    """The most worker processes allowed on this machine."""
    return JOBS_PER_CORE_MAX * (os.cpu_count() or 1)


def run_serial(fn: Callable[..., Any], tasks: Sequence[tuple],
               progress: Callable[[], Any] | None = None) -> list:
    """Every task in this process, one after the other."""
    out = []
    for task in tasks:
        out.append(fn(*task))
        if progress:
            progress()
    return out


@contextmanager
def _env(values: dict[str, str]) -> Iterator[None]:
    saved = {k: os.environ.get(k) for k in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@contextmanager
def process_pool(jobs: int, pin_threads: bool = True) -> Iterator[Runner]:
    """A runner on `jobs` worker processes of this machine; the pool is shut down on leaving
    (tasks not started are cancelled when a task fails or the run is interrupted)."""
    with _env(WORKER_THREAD_ENV if pin_threads else {}):
        pool = ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("forkserver"))
        try:
            yield lambda fn, tasks, progress=None: _gather(
                [pool.submit(fn, *t) for t in tasks], progress)
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


def _gather(futures: list, progress: Callable[[], Any] | None) -> list:
    index = {f: i for i, f in enumerate(futures)}
    out: list = [None] * len(futures)
    pending = set(futures)
    try:
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for f in done:
                out[index[f]] = f.result()
                if progress:
                    progress()
    except BaseException:
        for f in pending:
            f.cancel()
        raise
    return out


class SchedulerUnavailable(Exception):
    """Dask is not installed, or its scheduler cannot be reached (one line)."""


@contextmanager
def dask_scheduler(address: str) -> Iterator[Runner]:
    """A runner on the workers of the Dask scheduler at `address`; the client is closed on
    leaving. Raises SchedulerUnavailable before any task when Dask is missing or the scheduler
    does not answer within SCHEDULER_CONNECT_TIMEOUT_S."""
    try:
        from dask.distributed import Client
    except ImportError as exc:
        raise SchedulerUnavailable(f"needs dask.distributed, which is not installed here "
                                   f"({exc}); pip install 'uav_insar_planner[cluster]'") from None
    try:
        client = Client(address, timeout=SCHEDULER_CONNECT_TIMEOUT_S,
                        set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise SchedulerUnavailable(f"no Dask scheduler answers at {address} within "
                                   f"{SCHEDULER_CONNECT_TIMEOUT_S:g} s ({exc})") from None
    try:
        yield lambda fn, tasks, progress=None: _gather_dask(client, fn, tasks, progress)
    finally:
        client.close()


def _gather_dask(client: Any, fn: Callable[..., Any], tasks: Sequence[tuple],
                 progress: Callable[[], Any] | None) -> list:
    from dask.distributed import as_completed

    if not tasks:
        return []
    futures = client.map(fn, *zip(*tasks, strict=True), pure=False)
    index = {f.key: i for i, f in enumerate(futures)}
    out: list = [None] * len(futures)
    try:
        for f in as_completed(futures, loop=client.loop):
            out[index[f.key]] = f.result()
            if progress:
                progress()
    except BaseException:
        client.cancel(futures)
        raise
    return out
