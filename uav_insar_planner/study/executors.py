"""Run independent tasks `fn(*args)` serially, in a process pool or on a Dask cluster.

The one home of the parallel execution of sweeps and maps. A runner is called as
`run(fn, tasks, progress)` and returns `[fn(*t) for t in tasks]`: in the order of the tasks
whatever order they finish in, so a parallel run gives the serial run's rows value for value
(each solve is deterministic and sees the same inputs). `progress()` is called once per
finished task, as it arrives. `fn` must be a module-level function (pickled by reference).

Threads: a worker solves one problem at a time. Its BLAS / OpenMP pools are pinned to one
thread (WORKER_THREAD_ENV, set while the pool's processes start) so that N workers use N cores,
not N times the cores; Dask's nanny does the same for its workers by default. The serial run
(`serial()`) pins this process's pools to one thread too, for the libraries already loaded
(threadpoolctl) and those loaded later (the same variables): a BLAS sum split over two threads
is added in another order, and the last digits of a solve would differ from the workers'.
Workers start from a fork server, not by forking this process: a fork of a process with
threads (tqdm's monitor, OpenBLAS's pool) can deadlock, and Python 3.12 warns of it. Workers
ignore SIGINT: Ctrl-C reaches the whole process group, and it is this process's to stop the
run (cancel what has not started, wait for the running solves), not each worker's traceback.

A Dask scheduler is asked who it is and how many workers it has before the client connects,
the whole exchange bounded by SCHEDULER_CONNECT_TIMEOUT_S: distributed's own connect bounds
the TCP connect but not the handshake after it, so a port that accepts and never answers
would hang the client for good. A scheduler without workers is said at once, waited for up to
SCHEDULER_WORKERS_WAIT_S, then refused.
"""
from __future__ import annotations

import asyncio
import multiprocessing
import os
import signal
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from contextlib import contextmanager
from typing import Any, Protocol

WORKER_THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                     "MKL_NUM_THREADS": "1"}
JOBS_PER_CORE_MAX = 4  # --jobs at most this many per core: the solves are CPU-bound
SCHEDULER_CONNECT_TIMEOUT_S = 5.0  # a Dask scheduler that does not answer within this is an error
SCHEDULER_WORKERS_WAIT_S = 10.0  # how long a scheduler without workers is waited for
_WORKERS_POLL_S = 0.5


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
def serial() -> Iterator[Runner]:
    """run_serial with this process's BLAS / OpenMP pools pinned to one thread, as a worker's
    (module docstring); the limits and variables are restored on leaving."""
    from threadpoolctl import threadpool_limits

    with _env(WORKER_THREAD_ENV), threadpool_limits(limits=1):
        yield run_serial


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
        pool = ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("forkserver"),
                                   initializer=_ignore_sigint)
        try:
            yield lambda fn, tasks, progress=None: _gather(
                [pool.submit(fn, *t) for t in tasks], progress)
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


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
def dask_scheduler(address: str, say: Callable[[str], Any] = print) -> Iterator[Runner]:
    """A runner on the workers of the Dask scheduler at `address`; the client is closed on
    leaving. Raises SchedulerUnavailable before any task when Dask is missing, the scheduler
    does not answer within SCHEDULER_CONNECT_TIMEOUT_S, or it has no worker: that is said
    (`say`, one line) at once, and refused after SCHEDULER_WORKERS_WAIT_S without one."""
    try:
        from dask.distributed import Client
    except ImportError as exc:
        raise SchedulerUnavailable(f"needs dask.distributed, which is not installed here "
                                   f"({exc}); pip install 'uav_insar_planner[cluster]'") from None
    workers = _scheduler_workers(address)
    if not workers:
        say(f"the Dask scheduler at {address} has no workers; waiting up to "
            f"{SCHEDULER_WORKERS_WAIT_S:g} s for one")
        deadline = time.monotonic() + SCHEDULER_WORKERS_WAIT_S
        while not workers and time.monotonic() < deadline:
            time.sleep(_WORKERS_POLL_S)
            workers = _scheduler_workers(address)
        if not workers:
            raise SchedulerUnavailable(f"the Dask scheduler at {address} has no workers (waited "
                                       f"{SCHEDULER_WORKERS_WAIT_S:g} s); start `dask worker "
                                       f"{address} --nthreads 1` on each machine")
    try:
        client = Client(address, timeout=SCHEDULER_CONNECT_TIMEOUT_S,
                        set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise SchedulerUnavailable(_no_answer(address, exc)) from None
    try:
        yield lambda fn, tasks, progress=None: _gather_dask(client, fn, tasks, progress)
    finally:
        client.close()


def _no_answer(address: str, exc: BaseException) -> str:
    why = str(exc) or type(exc).__name__
    return (f"no Dask scheduler answers at {address} within {SCHEDULER_CONNECT_TIMEOUT_S:g} s "
            f"({why})")


def _scheduler_workers(address: str) -> int:
    """How many workers the scheduler at `address` has (its `identity`), the connect and the
    answer within SCHEDULER_CONNECT_TIMEOUT_S; SchedulerUnavailable (one line) otherwise."""
    from distributed.core import rpc
    from distributed.security import Security

    async def ask() -> dict:
        remote = rpc(address, connection_args=Security().get_connection_args("client"))
        try:
            return await asyncio.wait_for(remote.identity(n_workers=0),
                                          SCHEDULER_CONNECT_TIMEOUT_S)
        finally:
            await remote.close_rpc()

    try:
        info = asyncio.run(ask())
    except (OSError, asyncio.TimeoutError) as exc:
        raise SchedulerUnavailable(_no_answer(address, exc)) from None
    if not isinstance(info, dict) or info.get("type") != "Scheduler":
        kind = info.get("type") if isinstance(info, dict) else type(info).__name__
        raise SchedulerUnavailable(f"{address} answers as a {kind}, not a Dask scheduler")
    return int(info.get("n_workers", 0))


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
