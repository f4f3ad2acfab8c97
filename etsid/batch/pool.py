"""One function over a few items in warm worker processes, started at once (e.g. the run
reports of a fleet report, written while the caller draws the fleet's own page).

The workers are forked from the batch's fork server (:func:`etsid.batch.local.worker_context`,
with the caller's modules preloaded), one per core at most.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from etsid.batch.local import _stop, worker_context
from etsid.batch.run import default_jobs


class WarmPool:
    """``func`` over ``items`` in ``jobs`` worker processes (default: every core), started
    now; :meth:`results` waits for them in order. With one item or one job, :meth:`results`
    runs them in this process instead.

    An item whose worker process died (killed, crashed) gets the
    :class:`~concurrent.futures.process.BrokenProcessPool` error as its result; any other
    exception ``func`` raises is raised by :meth:`results`, as it would be here.
    """

    def __init__(self, func: Callable[[Any], Any], items: Sequence[Any],
                 preload: Sequence[str] = (), jobs: int | None = None) -> None:
        self.func, self.items = func, list(items)
        self.executor: ProcessPoolExecutor | None = None
        self.futures: list[Future[Any]] = []
        jobs = min(jobs or default_jobs(), len(self.items))
        if jobs > 1:
            self.executor = ProcessPoolExecutor(
                max_workers=jobs, mp_context=worker_context("pool", preload=tuple(preload)))
            self.futures = [self.executor.submit(func, item) for item in self.items]

    def results(self, progress: Callable[[int, Any], None] | None = None) -> list[Any]:
        """Each item's result, in order; ``progress(done, item)`` after each."""
        out: list[Any] = []
        try:
            for done, item in enumerate(self.items, 1):
                if self.executor is None:
                    out.append(self.func(item))
                else:
                    try:
                        out.append(self.futures[done - 1].result())
                    except BrokenProcessPool as err:
                        out.append(err)
                if progress is not None:
                    progress(done, item)
        except BaseException:
            self.close(cancel=True)
            raise
        self.close()
        return out

    def close(self, cancel: bool = False) -> None:
        """Shut the pool down (``cancel``: end the workers now)."""
        if self.executor is None:
            return
        if cancel:
            _stop(self.executor)
        else:
            self.executor.shutdown(wait=True)
        self.executor = None
