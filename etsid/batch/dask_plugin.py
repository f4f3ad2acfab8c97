"""The Dask worker plugin that warms each worker once (imported only when Dask is used)."""

from __future__ import annotations

import contextlib
import os
from typing import Any, ClassVar

from distributed import WorkerPlugin

from etsid.batch import tasks


class WarmWorker(WorkerPlugin):
    """Before its first log, a worker imports the command's modules, loads its numba
    kernels, keeps BLAS on one thread (unless the user set a count) and stops its
    statistical profiler (:data:`QUIET`) and wakes its event loop less often
    (:data:`SLOWER`). Dask runs it on every worker of the cluster, also on one that joins or
    is restarted later."""

    name = "etsid-warm"

    QUIET = ("profile", "profile-cycle")
    """The worker's periodic callbacks stopped while the plugin is installed: Dask's
    statistical profiler samples the running task's stack every 10 ms, 10–13 % more CPU
    per log measured on a command-line worker."""

    SLOWER: ClassVar[dict[str, float]] = {"tick": 1000.0, "monitor": 5000.0,
                                         "memory_monitor": 1000.0}
    """Periodic callbacks (name → interval, ms) that run less often while the plugin is
    installed, at the intervals the LocalCluster of ``--scheduler processes`` is
    configured with (:data:`etsid.batch.cluster.LOCAL_CONFIG`): a command-line worker
    measures its event loop every 20 ms, its memory every 100 ms and the system every
    500 ms, and each wake-up takes the GIL from the running log."""

    def __init__(self, command: str) -> None:
        self.command = command
        self.stopped: list[Any] = []
        self.slowed: list[tuple[Any, float]] = []

    def setup(self, worker: Any) -> None:
        from etsid.blas import BLAS_THREADS

        callbacks = getattr(worker, "periodic_callbacks", {})
        for name in self.QUIET:
            callback = callbacks.get(name)
            if callback is not None and callback.is_running():
                callback.stop()
                self.stopped.append(callback)
        for name, interval in self.SLOWER.items():
            callback = callbacks.get(name)
            if callback is not None and callback.callback_time < interval:
                self.slowed.append((callback, callback.callback_time))
                callback.callback_time = interval
        for module in tasks.PRELOAD:
            __import__(module)
        if not any(os.environ.get(key) for key in BLAS_THREADS):
            with contextlib.suppress(ImportError):
                from threadpoolctl import threadpool_limits

                threadpool_limits(limits=1, user_api="blas")
        tasks.warm(self.command)  # once per process (a forked worker is warm already)

    def teardown(self, worker: Any) -> None:
        """The profiler runs again, and the slowed callbacks at their own intervals, when
        the plugin is removed or replaced."""
        for callback in self.stopped:
            callback.start()
        self.stopped.clear()
        for callback, interval in self.slowed:
            callback.callback_time = interval
        self.slowed.clear()
