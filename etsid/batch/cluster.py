"""Run a batch on Dask distributed: an existing cluster, or a LocalCluster on this machine.

Nothing here schedules: every log is one ``client.submit`` of
:func:`etsid.batch.worker.run_log` and Dask places it. The batch's fixed arguments (options,
the resume keys) are scattered to the workers once. Run directories are written by the
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
from etsid.batch.worker import Item, Outcome, error_fields, run_log
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
        from dask.distributed import as_completed

        items = list(items)
        client, cluster = _client(self.address, self.jobs)
        futures: list[Any] = []
        try:
            workers = max(1, len(client.scheduler_info().get("workers", {})))
            client.run(tasks.warm, self.spec.command)
            spec, done = client.scatter([self.spec, self.done], broadcast=True)
            futures = [client.submit(run_log, item, spec, str(self.out), done, pure=False)
                       for item in items]
            owner = {f.key: item for f, item in zip(futures, items, strict=True)}
            left = len(futures)
            for future in as_completed(futures):
                on_running(min(workers, left))
                left -= 1
                try:
                    outcome = future.result()
                except Exception as err:  # the worker died (KilledWorker) or lost the task
                    item = owner[future.key]
                    row = {"input": item[1] if isinstance(item, tuple) else item,
                           "sim_input": item[0] if isinstance(item, tuple) else None,
                           "options_digest": self.spec.digest(), **error_fields(err)}
                    outcome = Outcome(item, None, row)
                on_done(outcome)
        except BaseException:
            client.cancel(futures)
            raise
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
