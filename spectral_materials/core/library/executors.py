"""Where library entries are factored: a local process pool, or a Dask cluster.

Both run ``fn(*job.args)`` for each job and yield ``(job, result, error)`` as jobs finish,
with at most ``2 × workers`` jobs in flight, so the file bytes a job carries are read
only when it is submitted (memory stays in proportion to the jobs running).

- :class:`LocalPool`: ``concurrent.futures.ProcessPoolExecutor`` (spawned processes, so
  the same on Linux, macOS and Windows). A worker that dies breaks the pool; the jobs it
  held run again one at a time, so the one that kills its worker is found and fails
  alone. A cancel terminates the workers.
- :class:`DaskCluster`: ``distributed.Client`` on a scheduler address. The scheduler
  itself runs a dead worker's tasks again on the others; a task whose scattered input
  died with its worker is submitted again (``MAX_TASK_ATTEMPTS``). Dask is needed only
  here: the extension never imports this.
"""

from __future__ import annotations

import collections
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
    """Jobs on ``workers`` local processes (default: the CPUs)."""

    def __init__(self, workers: int | None = None):
        if workers is not None and int(workers) < 1:
            raise ValueError(f"workers must be at least 1, got {workers}")
        self.workers = int(workers or os.cpu_count() or 1)
        self.name = f"local pool, {self.workers} worker{'s' * (self.workers != 1)}"

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        pass

    def run(self, fn: Callable, jobs: list[Job]) -> Iterator[Outcome]:
        with _threads_per_worker(self.workers):
            yield from self._run(fn, jobs)

    def _run(self, fn: Callable, jobs: list[Job]) -> Iterator[Outcome]:
        """A worker that dies breaks the pool and every job in it. Those jobs then run one
        at a time in a new pool: one that breaks it alone is the culprit and fails (it
        never takes the others down again); the rest run as usual."""
        pending = collections.deque(jobs)
        suspects: collections.deque = collections.deque()
        isolated: set[int] = set()
        context = multiprocessing.get_context("spawn")
        while pending or suspects:
            pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=context,
                                       initializer=_ignore_ctrl_c)
            running: dict = {}
            finished = alone = False
            try:
                while pending or suspects or running:
                    # Isolating while suspects wait or one runs (never beside other jobs).
                    alone = bool(suspects) or any(id(j) in isolated for j in running.values())
                    source = suspects if alone else pending
                    limit = 1 if alone else 2 * self.workers
                    while source and len(running) < limit:
                        job = source[0]
                        try:
                            args = job.load()
                        except OSError as exc:      # vanished or unreadable since hashing
                            source.popleft()
                            yield job, None, exc
                            continue
                        future = pool.submit(fn, *args)   # BrokenProcessPool: job stays
                        source.popleft()
                        running[future] = job
                    if not running:
                        continue
                    done, _ = wait(running, return_when=FIRST_COMPLETED)
                    broken = False
                    for future in done:
                        error = future.exception()
                        if isinstance(error, BrokenProcessPool):
                            broken = True               # the job stays in running
                            continue
                        job = running.pop(future)
                        yield job, (None if error else future.result()), error
                    if broken:
                        raise BrokenProcessPool()
                finished = True
            except BrokenProcessPool:
                lost = list(running.values())
                if alone and len(lost) == 1:
                    yield lost[0], None, RuntimeError(
                        f"{lost[0].label}: its worker process died while factoring it (out "
                        "of memory, or a crash in a native library)")
                else:
                    suspects.extend(lost)
                    isolated.update(id(job) for job in lost)
            finally:
                if not finished:
                    _terminate(pool)
                pool.shutdown(wait=finished, cancel_futures=True)


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Stop the pool's processes now: work already running would otherwise go on after a
    cancel (the workers ignore Ctrl-C) and delay the exit by whole factorisations."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        if process.is_alive():
            process.terminate()


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
        threads = self._threads()
        self.name = (f"Dask cluster at {self.address}, {len(threads)} workers, "
                     f"{sum(threads.values())} threads")
        return self

    def __exit__(self, *exc) -> None:
        if self.client is not None:
            self.client.close()

    def _threads(self) -> dict[str, int]:
        """Worker address → threads, as the scheduler knows them now."""
        workers = self.client.scheduler_info().get("workers", {})
        return {address: max(1, int(info.get("nthreads", 1)))
                for address, info in workers.items()}

    def run(self, fn: Callable, jobs: list[Job]) -> Iterator[Outcome]:
        """One task per worker thread in flight (recounted as workers come and go); each
        file's bytes are placed on the worker with the most free threads, and its task asks
        for that worker, so the work spreads over the cluster."""
        from distributed import as_completed

        pending = collections.deque(jobs)
        attempts: dict[int, int] = {}
        running: dict = {}
        completed = as_completed()

        def submit() -> Iterator[Outcome]:
            threads = self._threads()
            load = collections.Counter(where for _, _, where in running.values())
            # One task per worker thread: a task queued on a busy worker could wait behind a
            # long one (an RGL file) while another worker idles.
            while pending and threads and len(running) < sum(threads.values()):
                job = pending.popleft()
                try:
                    name, suffix, data, settings = job.load()
                except OSError as exc:          # vanished or unreadable since hashing
                    yield job, None, exc
                    continue
                where = min(threads, key=lambda a: load[a] / threads[a])
                load[where] += 1
                remote = self._scatter(data, where)
                future = self.client.submit(fn, name, suffix, remote, settings, pure=False,
                                            workers=[where], allow_other_workers=True)
                running[future.key] = (job, future, where)
                completed.add(future)

        yield from submit()
        for future in completed:
            job, _, _ = running.pop(future.key)
            try:
                result, error = future.result(), None
            except Exception as exc:        # the task's own error, or the cluster's
                result, error = None, exc
            future.release()
            if error is not None and _cluster_error(error):
                # A dead worker took the task or its scattered bytes: run it again.
                attempts[id(job)] = attempts.get(id(job), 0) + 1
                if attempts[id(job)] <= MAX_TASK_ATTEMPTS:
                    pending.appendleft(job)
                    yield from submit()
                    continue
            yield job, result, error
            yield from submit()

    def _scatter(self, data: bytes, worker: str):
        """``data`` on ``worker`` (or another, while the scheduler still names a dead one)."""
        for attempt in range(SCATTER_ATTEMPTS - 1):
            try:
                [remote] = self.client.scatter([data], hash=False,
                                               workers=[worker] if attempt == 0 else None)
                return remote
            except OSError:                 # CommClosedError: that worker just died
                time.sleep(0.5)
        [remote] = self.client.scatter([data], hash=False)      # the last try raises
        return remote


def _cluster_error(error: BaseException) -> bool:
    """Whether a task failed because of the cluster (a worker died, data was lost), not
    because of its input: distributed's own exceptions, cancellations, lost connections.
    ``KilledWorker`` is final: the scheduler has already run the task on several workers
    and each died, so the input itself kills them."""
    if type(error).__name__ == "KilledWorker":
        return False
    return (type(error).__module__.split(".")[0] == "distributed"
            or isinstance(error, OSError | CancelledError | TimeoutError))


def executor_for(scheduler: str | None, workers: int | None):
    """A :class:`DaskCluster` for a scheduler address, else a :class:`LocalPool`."""
    return DaskCluster(scheduler) if scheduler else LocalPool(workers)
