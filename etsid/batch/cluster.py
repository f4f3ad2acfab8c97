"""Run a batch on Dask distributed: an existing cluster, or a LocalCluster on this machine.

Nothing here schedules: logs go to Dask as tasks of :func:`run_chunk` (one log each in a
small batch, up to 8 in a large one, :func:`chunk_size`) and Dask places them; a task
whose worker dies on every retry is split into one task per log, so only the log that
kills its worker gets the error row. The batch's fixed arguments
(options, the resume keys) are two tasks every log depends on, sent once and recomputed if
the worker holding them dies. Each worker is warmed once (imports, numba kernels, one BLAS
thread) by a worker plugin, which Dask also runs on a worker that joins or is restarted. A
worker writes the log's run directory and its result row itself and sends back only the
status, so ``--out`` must be a path every worker sees (a shared file system). A log whose
worker dies on every try Dask allows (``distributed.scheduler.allowed-failures``) becomes a
"worker process died" row, written here, as in the local pool. Inputs are local paths the
workers see, or URLs they fetch themselves.

The LocalCluster of ``--scheduler processes`` listens on 127.0.0.1 only, serves no
dashboard unless asked (``--dashboard``), and forks its workers from the fork server of
the local pool, which has imported etsid and Dask and loaded the numba kernels once.

Needs ``dask[distributed]`` (``pip install "etsid[cluster]"``).
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

from etsid.batch.spec import BatchSpec
from etsid.batch.worker import Item, Outcome, WorkerDied, failed_outcome, run_and_write
from etsid.errors import BatchError

LOCAL_HOST = "127.0.0.1"
"""Where the LocalCluster's scheduler and workers listen."""

LOCAL_CONFIG = {
    "distributed.worker.multiprocessing-method": "forkserver",
    # the statistical profiler samples every thread every 10 ms: CPU a log pays for
    "distributed.worker.profile.enabled": False,
    # the workers' event loops wake less often (each wake-up takes the GIL from the log)
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
}
"""Dask configuration of the LocalCluster (its workers inherit it)."""

REPORT_ENV = "ETSID_DASK_REPORT"
"""Environment variable: a file name for Dask's performance report (HTML) of the batch."""


def scheduler_address(scheduler: str) -> str | None:
    """Dask scheduler address of ``--scheduler`` (None: a LocalCluster of processes).

    ``dask://HOST:PORT`` means ``tcp://HOST:PORT``; ``tcp://``, ``tls://`` and ``ws://``
    addresses are taken as they are.
    """
    if scheduler == "processes":
        return None
    if scheduler.startswith("dask://"):
        return "tcp://" + scheduler[len("dask://"):]
    return scheduler


def _local_cluster(jobs: int, command: str, dashboard: str | None) -> Any:
    import dask
    from dask.distributed import LocalCluster

    from etsid.batch.local import worker_context

    with dask.config.set(LOCAL_CONFIG):
        worker_context(command, preload=("distributed",))  # the fork server, warm
        # no dashboard: the scheduler's HTTP routes (health, metrics) on a free local port
        quiet = {} if dashboard else {"dashboard": False,
                                      "dashboard_address": f"{LOCAL_HOST}:0"}
        return LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True,
                            host=LOCAL_HOST, dashboard_address=dashboard,
                            worker_dashboard_address=None, scheduler_kwargs=quiet)


def _client(address: str | None, jobs: int, command: str,
            dashboard: str | None) -> tuple[Any, Any]:
    try:
        from dask.distributed import Client
    except ImportError as err:  # pragma: no cover - a test dependency
        raise BatchError('--scheduler processes/dask:// needs Dask distributed: '
                         'pip install "etsid[cluster]"') from err
    if address is None:
        cluster = _local_cluster(jobs, command, dashboard)
        return Client(cluster), cluster
    try:
        return Client(address, timeout="20s"), None
    except (OSError, TimeoutError, ValueError) as err:
        raise BatchError(f"cannot reach the Dask scheduler at {address} ({err})") from err


LOGS_PER_TASK_ENV = "ETSID_BATCH_LOGS_PER_TASK"
"""Environment variable that sets the logs per Dask task (default: :func:`chunk_size`)."""


def chunk_size(logs: int, workers: int, max_size: int = 8) -> int:
    """Logs per Dask task: 1 for a small batch; up to ``max_size`` when every worker still
    gets 16 tasks or more (Dask's per-task cost, a few ms of scheduling and messages, then
    weighs little against short logs, and the tail a worker waits for stays a few logs).
    ``ETSID_BATCH_LOGS_PER_TASK`` overrides it."""
    fixed = os.environ.get(LOGS_PER_TASK_ENV, "")
    if fixed.isdigit() and int(fixed) > 0:
        return int(fixed)
    return max(1, min(max_size, logs // (workers * 16)))


def run_chunk(items: list[Item], spec: BatchSpec, out: str,
              done: frozenset[str]) -> list[Outcome]:
    """Several logs in one Dask task, one after the other (each writes its own row)."""
    return [run_and_write(item, spec, out, done) for item in items]


def hold(value: Any) -> Any:
    """The task that keeps a batch argument in the cluster (its value is its argument)."""
    return value


@contextlib.contextmanager
def _diagnostics() -> Iterator[None]:
    """Dask's performance report of the batch when ``ETSID_DASK_REPORT`` names a file."""
    target = os.environ.get(REPORT_ENV)
    if not target:
        yield
        return
    from dask.distributed import performance_report

    with performance_report(filename=target):
        yield


class DaskRunner:
    """Runs logs on Dask workers and reports each :class:`Outcome` as it finishes.

    ``timings`` records the phases (s): cluster start, warming the workers, submitting,
    and the wait for the results.
    """

    def __init__(self, spec: BatchSpec, out: Path, done: frozenset[str], jobs: int,
                 address: str | None, dashboard: str | None = None) -> None:
        self.spec = spec
        self.out = out
        self.done = done
        self.jobs = jobs
        self.address = address
        self.dashboard = dashboard
        self.timings: dict[str, float] = {}

    def run(self, items: Iterable[Item], on_done: Callable[[Outcome], None],
            on_running: Callable[[int], None]) -> None:
        """Run every item; Ctrl-C cancels what is left and re-raises."""
        from dask.distributed import KilledWorker, as_completed

        from etsid.batch.dask_plugin import WarmWorker

        items = list(items)
        start = time.perf_counter()
        client, cluster = _client(self.address, self.jobs, self.spec.command, self.dashboard)
        self.timings["cluster_s"] = time.perf_counter() - start
        futures: list[Any] = []
        try:
            with _diagnostics():
                mark = time.perf_counter()
                client.register_plugin(WarmWorker(self.spec.command))
                self.timings["warm_s"] = time.perf_counter() - mark
                workers = max(1, len(client.scheduler_info().get("workers", {})))
                mark = time.perf_counter()
                # tasks, not scattered data: a worker that dies takes its copy with it, and
                # the scheduler recomputes a lost task's value where scattered data is gone
                spec = client.submit(hold, self.spec, pure=False)
                done = client.submit(hold, self.done, pure=False)
                size = chunk_size(len(items), workers)
                owner: dict[Any, list[Item]] = {}
                for chunk in (items[i:i + size] for i in range(0, len(items), size)):
                    future = client.submit(run_chunk, chunk, spec, str(self.out), done,
                                           pure=False)
                    futures.append(future)
                    owner[future.key] = chunk
                self.timings["submit_s"] = time.perf_counter() - mark
                self.timings["logs_per_task"] = size
                mark = time.perf_counter()
                left = len(items)
                pending = as_completed(futures)
                for future in pending:
                    chunk = owner.pop(future.key)
                    try:
                        outcomes = future.result()
                    except KilledWorker:  # its worker died on every retry Dask allowed
                        if len(chunk) > 1:  # again log by log: only the culprit fails
                            for item in chunk:
                                single = client.submit(run_chunk, [item], spec,
                                                       str(self.out), done, pure=False)
                                owner[single.key] = [item]
                                futures.append(single)
                                pending.add(single)
                            continue
                        outcomes = [failed_outcome(chunk[0], self.spec, WorkerDied())]
                    except BatchError:  # the worker could not write (a full disk)
                        raise
                    except Exception as err:  # the scheduler lost the task
                        outcomes = [failed_outcome(item, self.spec, err) for item in chunk]
                    for outcome in outcomes:
                        on_running(min(workers, left))
                        left -= 1
                        on_done(outcome)
                    future.release()
                self.timings["results_s"] = time.perf_counter() - mark
        except BaseException:
            client.cancel(futures)
            raise
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
