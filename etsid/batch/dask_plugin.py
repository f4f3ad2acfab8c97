"""The Dask worker plugin that warms each worker once (imported only when Dask is used)."""

from __future__ import annotations

import contextlib
import os
from typing import Any

from distributed import WorkerPlugin

from etsid.batch import tasks


class WarmWorker(WorkerPlugin):
    """Before its first log, a worker imports the command's modules, loads its numba
    kernels and keeps BLAS on one thread (unless the user set a count). Dask runs it on
    every worker of the cluster, also on one that joins or is restarted later."""

    name = "etsid-warm"

    def __init__(self, command: str) -> None:
        self.command = command

    def setup(self, worker: Any) -> None:
        from etsid.batch.local import BLAS_THREADS

        for module in tasks.PRELOAD:
            __import__(module)
        if not any(os.environ.get(key) for key in BLAS_THREADS):
            with contextlib.suppress(ImportError):
                from threadpoolctl import threadpool_limits

                threadpool_limits(limits=1, user_api="blas")
        if self.command not in _WARMED:  # a worker of a long-lived cluster: warm once
            tasks.warm(self.command)
            _WARMED.add(self.command)


_WARMED: set[str] = set()
"""Commands this worker process has warmed up for."""
