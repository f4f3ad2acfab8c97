"""Run a batch on this machine: in this process (``--jobs 1``) or a pool of processes.

The pool is a :class:`concurrent.futures.ProcessPoolExecutor` on the ``forkserver``
context: workers start from a server that has imported etsid and loaded the numba kernels
once. Logs are submitted through a window of :data:`WINDOW` per worker, so a worker never
waits for the parent between logs and few logs are in flight when something goes wrong.
Every worker reports its resident memory after each log; the pool is replaced by a fresh
one only when a worker has grown by more than :data:`RENEW_GROWTH_MB` since its first log
(memory held after one log never accumulates; the pool is renewed whole because
``max_tasks_per_child`` can hang Python 3.11's executor when a worker retires). An optional
RSS watchdog (``--max-memory``) turns a runaway log into a ``MemoryError`` row instead of
the kernel's OOM killer. A worker that dies anyway (killed, crashed) breaks the pool: the
logs in flight go to a new pool, and a log that breaks a pool twice is run alone, so the
one that kills its worker is the only one to get the error row.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
from collections import Counter, deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import forkserver
from pathlib import Path
from typing import Any

from etsid.batch import tasks
from etsid.batch.lifeline import PARENT_ENV
from etsid.batch.limits import RENEW_GROWTH_MB as RENEW_GROWTH_MB
from etsid.batch.spec import BatchSpec
from etsid.batch.worker import (
    Item,
    Outcome,
    WorkerDied,
    failed_outcome,
    init_worker,
    run_log,
    run_pooled,
)
from etsid.blas import BLAS_THREADS, one_blas_thread

WINDOW = 2
"""Logs submitted per worker at a time (the one running and the next)."""

WATCH_S = 5.0
"""s between checks, while no log finishes, that every worker of the pool is still alive: a
worker killed at the wrong moment can leave the pool waiting on it for ever (seen in CI:
the batch of tests/batch/test_batch_worker_death.py hung ten minutes with one worker
gone), so a dead worker breaks the pool here as it would in the executor."""

def worker_context(command: str, preload: tuple[str, ...] = ()) -> Any:
    """The forkserver context (spawn where there is none), preloaded with etsid's modules
    (and ``preload``) and, for identify, the loaded numba kernels. The server is one per
    process: the modules of whoever starts it first are the ones preloaded."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        tasks.warm(command)  # compile once here; spawned workers load the cache
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    warm = ["etsid.batch.preload_identify"] if command == "identify" else []
    ctx.set_forkserver_preload(["etsid.batch.preload_server", *preload, "etsid.batch.worker",
                                *tasks.PRELOAD, *warm, "etsid.batch.preload_freeze"])
    # start the server with Ctrl-C ignored: it and the workers it forks inherit that, so
    # Ctrl-C reaches only this process, which stops the pool
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with server_env():
            forkserver.ensure_running()
    finally:
        signal.signal(signal.SIGINT, previous)
    return ctx



@contextlib.contextmanager
def server_env() -> Iterator[None]:
    """Environment for starting the fork server (and so for every worker).

    * It must import this very etsid: Python 3.11's fork server imports its preload modules
      before it takes this process's ``sys.path``, with the current directory first
      (``python -c``), so run from a directory holding another etsid the workers would run
      that one. ``PYTHONSAFEPATH`` drops the current directory and ``PYTHONPATH`` leads
      with the directory this etsid comes from.
    * The server dies with this process (:mod:`etsid.batch.lifeline`), and the workers
      with the server.
    * One BLAS thread per worker: the workers already fill the cores, and OpenBLAS's own
      threads only wait for each other (13 % more CPU per log measured, no gain).
    """
    import etsid

    root = str(Path(etsid.__file__).resolve().parents[1])
    saved = {key: os.environ.get(key)
             for key in ("PYTHONSAFEPATH", "PYTHONPATH", PARENT_ENV, *BLAS_THREADS)}
    os.environ["PYTHONSAFEPATH"] = "1"
    os.environ[PARENT_ENV] = str(os.getpid())  # the server dies with this process
    os.environ["PYTHONPATH"] = os.pathsep.join(
        [root, *([saved["PYTHONPATH"]] if saved["PYTHONPATH"] else [])])
    for key in BLAS_THREADS:
        os.environ.setdefault(key, "1")
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


class LocalRunner:
    """Runs logs and reports each :class:`Outcome` to ``on_done`` as it finishes.

    Parameters
    ----------
    jobs
        Processes; 1 runs every log in this process, one after the other.
    max_memory_mb
        RSS limit of each worker, MB (None: no limit).
    """

    def __init__(self, spec: BatchSpec, out: Path, done: frozenset[str], jobs: int,
                 max_memory_mb: float | None = None) -> None:
        self.spec = spec
        self.out = out
        self.done = done
        self.jobs = jobs
        self.max_memory_mb = max_memory_mb
        if jobs > 1:  # start the fork server now: it imports and warms up meanwhile
            worker_context(spec.command)

    def run(self, items: Iterable[Item], on_done: Callable[[Outcome], None],
            on_running: Callable[[int], None]) -> None:
        """Run every item; Ctrl-C stops the workers and re-raises :class:`KeyboardInterrupt`."""
        items = list(items)
        if self.jobs <= 1:
            with one_blas_thread():  # as the pool workers run (etsid.blas)
                for item in items:
                    on_running(1)
                    on_done(run_log(item, self.spec, self.out, self.done))
            return
        breaks: Counter[Item] = Counter()
        pending = deque(items)
        while pending:
            self._pool_pass(pending, breaks, on_done, on_running, self.jobs)
            for item in [item for item in pending if breaks[item] >= 2]:
                pending.remove(item)
                alone = deque([item])
                self._pool_pass(alone, breaks, on_done, on_running, 1)
                if alone:
                    on_done(failed_outcome(item, self.spec, WorkerDied()))

    def _pool_pass(self, pending: deque[Item], breaks: Counter[Item],
                   on_done: Callable[[Outcome], None], on_running: Callable[[int], None],
                   jobs: int) -> None:
        """Run logs from the front of ``pending`` in one pool until none are left, the pool
        breaks (the logs in flight go back to the front) or a worker has grown too much."""
        jobs = min(jobs, len(pending))
        executor = ProcessPoolExecutor(
            max_workers=jobs, mp_context=worker_context(self.spec.command),
            initializer=init_worker,
            initargs=(self.spec, str(self.out), self.done, self.max_memory_mb))
        flying: dict[Future[Outcome], Item] = {}
        first_rss: dict[int, float] = {}
        renew = broken = False
        try:
            while pending or flying:
                while pending and not (renew or broken) and len(flying) < WINDOW * jobs:
                    try:
                        future = executor.submit(run_pooled, pending[0])
                    except BrokenProcessPool:  # a worker died since the last wait: the
                        broken = True  # item never ran, so no break counts against it
                        break
                    flying[future] = pending.popleft()
                if not flying:
                    break
                on_running(min(jobs, len(flying)))
                finished, _ = wait(flying, timeout=WATCH_S, return_when=FIRST_COMPLETED)
                if not finished and _lost_worker(executor):
                    for item in flying.values():
                        breaks[item] += 1
                        pending.appendleft(item)
                    flying.clear()
                    _stop(executor)
                    return
                for future in finished:
                    item = flying.pop(future)
                    try:
                        outcome = future.result()
                    except BrokenProcessPool:
                        breaks[item] += 1
                        broken = True
                        pending.appendleft(item)
                        continue
                    if outcome.pid is not None and outcome.rss_mb is not None:
                        first = first_rss.setdefault(outcome.pid, outcome.rss_mb)
                        renew = renew or outcome.rss_mb - first > RENEW_GROWTH_MB
                    on_done(outcome)
        except BaseException:
            _stop(executor)
            raise
        executor.shutdown(wait=True)


def _lost_worker(executor: ProcessPoolExecutor) -> bool:
    """Whether a worker process of ``executor`` has exited while it still runs the pool."""
    processes = getattr(executor, "_processes", None) or {}
    return any(p.exitcode is not None for p in list(processes.values()))


def _stop(executor: ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the pool's worker processes now."""
    executor.shutdown(wait=False, cancel_futures=True)
    for child in multiprocessing.active_children():
        child.terminate()
    for child in multiprocessing.active_children():
        child.join(timeout=5)
