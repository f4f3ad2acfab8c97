"""BLAS on one thread: identify and the gap analysis while they run, a batch's own process
(``--jobs 1``).

identify's linear algebra is skinny (tens of columns, thousands of rows: ARX fits, scores,
norms). OpenBLAS splits such products over its threads, and on a shared machine those
threads mostly wait for each other: measured on the 600 s benchmark flight
(``python benchmarks/identify.py --phases``), the ARX fits alone took 0.3 s of CPU each
with the default threads and a few ms with one (docs/performance.md). A thread count the
user set (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``) is kept.
A batch with ``--jobs 1`` then spends the CPU per log a pool worker does (0.148 s instead of
0.266 s for a 25 s flight, measured).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator

BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""Environment variables that set a BLAS thread count; any of them set: leave BLAS alone
(the batch sets them to 1 in its pool workers)."""


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with every loaded BLAS on one thread (unless the user chose a count)."""
    if any(os.environ.get(key) for key in BLAS_THREADS):
        yield
        return
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - a dependency; then BLAS keeps its threads
        yield
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield
