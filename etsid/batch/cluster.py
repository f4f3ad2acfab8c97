"""Run a batch on Dask distributed: an existing cluster, or a LocalCluster on this machine.

Nothing here schedules: every log is one ``client.submit`` of
:func:`etsid.batch.worker.run_log` and Dask places it. The batch's fixed arguments (options,
the resume keys) are two tasks every log depends on, sent once and recomputed if the worker
holding them dies. A log whose worker dies on every try Dask allows
(``distributed.scheduler.allowed-failures``) becomes a "worker process died" row, as in the
local pool. Run directories are written by the
workers, so ``--out`` must be a path every worker sees (a shared file system); the result
rows come back to this process, which writes ``DIR/results/``. Inputs are local paths the
workers see, or fsspec URLs (``s3://…``) they fetch themselves.

Needs ``dask[distributed]`` (``pip install "etsid[cluster]"``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from etsid.batch import tasks
from etsid.batch.spec import BatchSpec
from etsid.batch.worker import Item, Outcome, WorkerDied, failed_outcome, run_log
from etsid.errors import BatchError


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


def _client(address: str | None, jobs: int) -> tuple[Any, Any]:
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as err:
        raise BatchError('--scheduler processes/dask:// needs Dask distributed: '
                         'pip install "etsid[cluster]"') from err
    if address is None:
        cluster = LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True,
                               dashboard_address=":0")
        return Client(cluster), cluster
    try:
        return Client(address, timeout="20s"), None
    except (OSError, TimeoutError) as err:
        raise BatchError(f"cannot reach the Dask scheduler at {address} ({err})") from err


def hold(value: Any) -> Any:
    """The task that keeps a batch argument in the cluster (its value is its argument)."""
    return value


class DaskRunner:
    """Runs logs on Dask workers and reports each :class:`Outcome` as it finishes."""

    def __init__(self, spec: BatchSpec, out: Path, done: frozenset[str], jobs: int,
                 address: str | None) -> None:
        self.spec = spec
        self.out = out
        self.done = done
        self.jobs = jobs
        self.address = address

    def run(self, items: Iterable[Item], on_done: Callable[[Outcome], None],
            on_running: Callable[[int], None]) -> None:
        """Run every item; Ctrl-C cancels what is left and re-raises."""
        from dask.distributed import KilledWorker, as_completed

        items = list(items)
        client, cluster = _client(self.address, self.jobs)
        futures: list[Any] = []
        try:
            workers = max(1, len(client.scheduler_info().get("workers", {})))
            client.run(tasks.warm, self.spec.command)
            # tasks, not scattered data: a worker that dies takes its copy with it, and
            # the scheduler recomputes a lost task's value where scattered data is gone
            spec = client.submit(hold, self.spec, pure=False)
            done = client.submit(hold, self.done, pure=False)
            futures = [client.submit(run_log, item, spec, str(self.out), done, pure=False)
                       for item in items]
            owner = {f.key: item for f, item in zip(futures, items, strict=True)}
            left = len(futures)
            for future in as_completed(futures):
                on_running(min(workers, left))
                left -= 1
                try:
                    outcome = future.result()
                except KilledWorker:  # its worker died on every retry Dask allowed
                    outcome = failed_outcome(owner[future.key], self.spec, WorkerDied())
                except Exception as err:  # the scheduler lost the task, or a worker error
                    outcome = failed_outcome(owner[future.key], self.spec, err)
                on_done(outcome)
        except BaseException:
            client.cancel(futures)
            raise
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
