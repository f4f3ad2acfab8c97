"""Dask nanny preload: a host's ``dask worker`` processes forked from one warm server.

    dask worker tcp://SCHED:8786 --nworkers 8 --nthreads 1 \\
        --preload-nanny etsid.batch.dask_host

Without it each worker process a ``dask worker`` command starts imports etsid, pandas,
Arrow and numba and loads the eTS kernels on its own: every worker holds a private copy
(about 140 MB). With it, the nannies of the command start their workers from the fork
server of the local pool (:func:`etsid.batch.local.worker_context`, Dask's
``multiprocessing-method: forkserver``), which has imported etsid and Dask and loaded the
kernels once; the workers share those pages, as the local pool's and the LocalCluster's
workers do, and a worker that the nanny restarts is born warm. The server dies with the
``dask worker`` command.
"""

from __future__ import annotations

import os
from typing import Any

METHOD = "distributed.worker.multiprocessing-method"
"""Dask's setting of how a nanny starts its worker process."""


def dask_setup(nanny: Any) -> None:
    """Before the nanny starts its worker: fork workers from etsid's warm fork server."""
    import dask

    from etsid.batch.local import worker_context

    dask.config.set({METHOD: "forkserver"})
    # what the nanny sets before it starts a worker (MALLOC_TRIM_THRESHOLD_, one BLAS
    # thread): a forked worker gets the server's environment, so the server needs it
    os.environ.update(getattr(nanny, "pre_spawn_env", None) or {})
    worker_context("identify", preload=("distributed",))
