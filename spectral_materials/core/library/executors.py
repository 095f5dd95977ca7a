"""Where library entries are factored: a local process pool, or a Dask cluster.

Both run ``fn(*job.args)`` for each job and yield ``(job, result, error)`` as jobs finish,
with at most ``2 × workers`` jobs in flight, so the file bytes a job carries are read
only when it is submitted (memory stays in proportion to the jobs running).

- :class:`LocalPool`: ``concurrent.futures.ProcessPoolExecutor`` (spawned processes, so
  the same on Linux, macOS and Windows). A worker that dies breaks the pool; the pool
  is started again and the jobs that had not finished are submitted again
  (``MAX_POOL_RESTARTS`` times).
- :class:`DaskCluster`: ``distributed.Client`` on a scheduler address. The scheduler
  itself runs a dead worker's tasks again on the others; a task whose scattered input
  died with its worker is submitted again (``MAX_TASK_ATTEMPTS``). Dask is needed only
  here: the extension never imports this.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, CancelledError, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

#: Times a local pool is started again after a worker died, before the jobs fail.
MAX_POOL_RESTARTS = 3
#: Seconds to wait for a Dask scheduler to answer.
CONNECT_TIMEOUT = 10.0
#: Times a Dask task is submitted again after the cluster (not its input) failed it.
MAX_TASK_ATTEMPTS = 3
#: Tries to place a file's bytes on a worker (0.5 s apart).
SCATTER_ATTEMPTS = 10


@dataclass
class Job:
    """One call: ``load()`` gives its arguments when it is submitted; ``label`` names it."""

    label: str
    load: Callable[[], tuple]
    data: Any = None


#: What ``run`` yields per job: the job, its result (None on error), its error or None.
Outcome = tuple[Job, Any, "BaseException | None"]


class SchedulerUnreachable(OSError):
    """The Dask scheduler did not answer (the message names it)."""


class LocalPool:
    """Jobs on ``workers`` local processes (default: the CPUs, at least 1)."""

    def __init__(self, workers: int | None = None):
        self.workers = max(1, int(workers or os.cpu_count() or 1))
        self.name = f"local pool, {self.workers} worker{'s' * (self.workers != 1)}"

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        pass

    def run(self, fn: Callable, jobs: list[Job]) -> Iterator[Outcome]:
        with _threads_per_worker(self.workers):
            yield from self._run(fn, jobs)

    def _run(self, fn: Callable, jobs: list[Job]) -> Iterator[Outcome]:
        pending = list(jobs)[::-1]
        restarts = 0
        while pending:
            context = multiprocessing.get_context("spawn")
            pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=context,
                                       initializer=_ignore_ctrl_c)
            running: dict = {}
            try:
                while pending or running:
                    while pending and len(running) < 2 * self.workers:
                        job = pending.pop()
                        running[pool.submit(fn, *job.load())] = job
                    done, _ = wait(running, return_when=FIRST_COMPLETED)
                    for future in done:
                        error = future.exception()
                        if isinstance(error, BrokenProcessPool):
                            raise error           # the job stays in running: rerun below
                        job = running.pop(future)
                        yield job, (None if error else future.result()), error
            except BrokenProcessPool:
                restarts += 1
                # Every job still running is lost with the pool: run them again.
                pending.extend(running.values())
                if restarts > MAX_POOL_RESTARTS:
                    for job in pending:
                        yield job, None, RuntimeError(
                            f"{job.label}: a worker process died {restarts} times")
                    pending = []
            finally:
                pool.shutdown(wait=False, cancel_futures=True)


#: The variables NumPy's BLAS and OpenMP read for their thread count.
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@contextlib.contextmanager
def _threads_per_worker(workers: int):
    """Spawned workers inherit the environment: each gets cores / workers BLAS threads, so
    that N workers do not each start a thread per core (on 2 cores, 2 workers of 2 threads
    ran at 0.49× a sequential loop). Variables the user set are left alone."""
    share = str(max(1, (os.cpu_count() or 1) // workers))
    added = [name for name in THREAD_VARIABLES if name not in os.environ]
    for name in added:
        os.environ[name] = share
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


def _ignore_ctrl_c() -> None:
    """Workers leave Ctrl-C to the building process, which stops submitting, writes the
    index and shuts the pool down (a terminal sends SIGINT to the whole process group)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class DaskCluster:
    """Jobs on the Dask cluster whose scheduler is at ``address`` (``tcp://host:port``)."""

    def __init__(self, address: str):
        self.address = address
        self.client = None
        self.name = f"Dask cluster at {address}"

    def __enter__(self):
        try:
            from distributed import Client
        except ImportError:
            raise SchedulerUnreachable(
                f"the Dask scheduler at {self.address} needs Dask installed: "
                "pip install -r requirements/cli.txt") from None
        try:
            self.client = Client(self.address, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            raise SchedulerUnreachable(
                f"the Dask scheduler at {self.address} cannot be reached: {exc}") from None
        workers = len(self.client.scheduler_info().get("workers", {}))
        self.name = f"Dask cluster at {self.address}, {workers} workers"
        return self

    def __exit__(self, *exc) -> None:
        if self.client is not None:
            self.client.close()

    def run(self, fn: Callable, jobs: list[Job]) -> Iterator[Outcome]:
        from distributed import as_completed

        workers = max(1, len(self.client.scheduler_info().get("workers", {})))
        pending = list(jobs)[::-1]
        attempts: dict[int, int] = {}
        running: dict = {}
        completed = as_completed()

        def submit() -> None:
            while pending and len(running) < 2 * workers:
                job = pending.pop()
                name, suffix, data, settings = job.load()
                # Scattered first: large file bytes travel to a worker, not in the graph.
                remote = self._scatter(data)
                future = self.client.submit(fn, name, suffix, remote, settings, pure=False)
                running[future.key] = (job, future)
                completed.add(future)

        submit()
        for future in completed:
            job, _ = running.pop(future.key)
            try:
                result, error = future.result(), None
            except Exception as exc:        # the task's own error, or the cluster's
                result, error = None, exc
            future.release()
            if error is not None and _cluster_error(error):
                # A dead worker took the task or its scattered bytes: run it again.
                attempts[id(job)] = attempts.get(id(job), 0) + 1
                if attempts[id(job)] <= MAX_TASK_ATTEMPTS:
                    pending.append(job)
                    submit()
                    continue
            yield job, result, error
            submit()

    def _scatter(self, data: bytes):
        """``data`` on a worker; retried while the scheduler still names a dead one."""
        for attempt in range(SCATTER_ATTEMPTS):
            try:
                [remote] = self.client.scatter([data], hash=False)
                return remote
            except OSError:                 # CommClosedError: that worker just died
                if attempt == SCATTER_ATTEMPTS - 1:
                    raise
                time.sleep(0.5)
        raise AssertionError("unreachable")


def _cluster_error(error: BaseException) -> bool:
    """Whether a task failed because of the cluster (a worker died, data was lost), not
    because of its input: distributed's own exceptions, cancellations, lost connections."""
    return (type(error).__module__.split(".")[0] == "distributed"
            or isinstance(error, OSError | CancelledError | TimeoutError))


def executor_for(scheduler: str | None, workers: int | None):
    """A :class:`DaskCluster` for a scheduler address, else a :class:`LocalPool`."""
    return DaskCluster(scheduler) if scheduler else LocalPool(workers)
