"""Run a batch on this machine: in this process (``--jobs 1``) or a pool of processes.

The pool is a :class:`concurrent.futures.ProcessPoolExecutor` on the ``forkserver``
context: workers start from a server that has imported etsid once, the pool is replaced by
a fresh one after :data:`TASKS_PER_CHILD` logs per worker (memory held by one log never
accumulates; the pool is renewed whole because ``max_tasks_per_child`` can hang
Python 3.11's executor when a worker retires), and an
optional address-space limit (``--max-memory``) turns a runaway log into a
``MemoryError`` row instead of the kernel's OOM killer. A worker that dies anyway (killed,
crashed) breaks the pool: the unfinished logs go to a new pool, and a log that breaks a
pool twice is run alone, so the one that kills its worker is the only one to get the
error row.
"""

from __future__ import annotations

import multiprocessing
import signal
from collections import Counter
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import forkserver
from pathlib import Path
from typing import Any

from etsid.batch import tasks
from etsid.batch.spec import BatchSpec
from etsid.batch.worker import Item, Outcome, error_fields, init_worker, run_log, run_pooled

TASKS_PER_CHILD = 50
"""Logs per pool process before the pool is replaced by a fresh one."""

WORKER_DIED = ("worker process died while reading this log (killed by the system, "
               "probably out of memory, or crashed)")


def _context(command: str) -> Any:
    """The forkserver context (spawn where there is none), preloaded with etsid's modules
    and, for identify, the loaded numba kernels."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        tasks.warm(command)  # compile once here; spawned workers load the cache
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    warm = ["etsid.batch.preload_identify"] if command == "identify" else []
    ctx.set_forkserver_preload(["etsid.batch.worker", *tasks.PRELOAD, *warm])
    # start the server with Ctrl-C ignored: it and the workers it forks inherit that, so
    # Ctrl-C reaches only this process, which stops the pool
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        forkserver.ensure_running()
    finally:
        signal.signal(signal.SIGINT, previous)
    return ctx


def _died(item: Item, spec: BatchSpec) -> Outcome:
    row = {"input": item[1] if isinstance(item, tuple) else item,
           "sim_input": item[0] if isinstance(item, tuple) else None,
           "options_digest": spec.digest(), **error_fields(RuntimeError(WORKER_DIED))}
    row["error"] = WORKER_DIED
    row["error_kind"] = "WorkerDied"
    return Outcome(item, None, row)


class LocalRunner:
    """Runs logs and reports each :class:`Outcome` to ``on_done`` as it finishes.

    Parameters
    ----------
    jobs
        Processes; 1 runs every log in this process, one after the other.
    on_start
        Called with the number of logs running now, whenever it changes.
    """

    def __init__(self, spec: BatchSpec, out: Path, done: frozenset[str], jobs: int,
                 max_memory_mb: float | None = None) -> None:
        self.spec = spec
        self.out = out
        self.done = done
        self.jobs = jobs
        self.max_memory_mb = max_memory_mb

    def run(self, items: Iterable[Item], on_done: Callable[[Outcome], None],
            on_running: Callable[[int], None]) -> None:
        """Run every item; Ctrl-C stops the workers and re-raises :class:`KeyboardInterrupt`."""
        items = list(items)
        if self.jobs <= 1:
            for item in items:
                on_running(1)
                on_done(run_log(item, self.spec, self.out, self.done))
            return
        breaks: Counter[Item] = Counter()
        chunk = self.jobs * TASKS_PER_CHILD
        for start in range(0, len(items), chunk):  # a fresh pool per chunk
            pending = items[start:start + chunk]
            while pending:
                pending = self._pool_pass(pending, breaks, on_done, on_running, self.jobs)
                alone = [item for item in pending if breaks[item] >= 2]
                pending = [item for item in pending if breaks[item] < 2]
                for item in alone:
                    if self._pool_pass([item], breaks, on_done, on_running, 1):
                        on_done(_died(item, self.spec))

    def _pool_pass(self, items: list[Item], breaks: Counter[Item],
                   on_done: Callable[[Outcome], None], on_running: Callable[[int], None],
                   jobs: int) -> list[Item]:
        """Run ``items`` in one pool; returns those left unfinished by a broken pool."""
        executor = ProcessPoolExecutor(
            max_workers=min(jobs, len(items)), mp_context=_context(self.spec.command),
            initializer=init_worker,
            initargs=(self.spec, str(self.out), self.done, self.max_memory_mb))
        unfinished: list[Item] = []
        try:
            futures: dict[Future[Outcome], Item] = {
                executor.submit(run_pooled, item): item for item in items}
            waiting = set(futures)
            while waiting:
                on_running(min(jobs, len(waiting)))
                finished, waiting = wait(waiting, return_when=FIRST_COMPLETED)
                for future in finished:
                    try:
                        outcome = future.result()
                    except BrokenProcessPool:
                        breaks[futures[future]] += 1
                        unfinished.append(futures[future])
                        continue
                    on_done(outcome)
        except BaseException:
            _stop(executor)
            raise
        executor.shutdown(wait=True)
        return unfinished


def _stop(executor: ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the pool's worker processes now."""
    executor.shutdown(wait=False, cancel_futures=True)
    for child in multiprocessing.active_children():
        child.terminate()
    for child in multiprocessing.active_children():
        child.join(timeout=5)
