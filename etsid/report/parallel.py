"""Several run reports at once, one process each (the fleet report's best and worst flights).

A run's report is a few seconds of matplotlib and Bokeh work for one core; the fleet report
writes up to ten of them. They go to a pool of worker processes forked from the batch's
fork server (:func:`etsid.batch.local.worker_context`), preloaded with the report's modules
so that no worker imports matplotlib or Bokeh again, while this process draws the fleet's
own page.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from etsid.errors import EtsidError

PRELOAD = ("etsid.report.build", "etsid.report.run_plots", "etsid.report.interactive",
           "etsid.report.overview", "bokeh.plotting", "bokeh.embed",
           "matplotlib.backends.backend_agg")
"""Modules the pool's fork server imports once, before it forks the workers."""


def write_report(run_dir: str) -> str | None:
    """Write ``run_dir``'s report (in a worker): None, or the one-line reason it failed
    (an :class:`~etsid.errors.EtsidError`: not a run directory, unreadable files)."""
    from etsid.report.build import make_report

    try:
        make_report(run_dir)
    except EtsidError as err:
        return str(err)
    return None


class ReportPool:
    """Run reports written by ``jobs`` worker processes (in this process when ``jobs`` is
    1 or there is one report), started at once; :meth:`results` waits for them.

    Other exceptions than :class:`~etsid.errors.EtsidError` in a worker are raised by
    :meth:`results`, as they would be in this process.
    """

    def __init__(self, run_dirs: list[Path], jobs: int) -> None:
        self.run_dirs = run_dirs
        self.executor: ProcessPoolExecutor | None = None
        self.futures: list[Future[str | None]] = []
        jobs = min(jobs, len(run_dirs))
        if jobs > 1:
            from etsid.batch.local import worker_context

            self.executor = ProcessPoolExecutor(
                max_workers=jobs, mp_context=worker_context("report", preload=PRELOAD))
            self.futures = [self.executor.submit(write_report, str(d)) for d in run_dirs]

    def results(self, progress: Callable[[int, Path], None] | None = None
                ) -> dict[Path, str | None]:
        """Run directory → None (report written) or why it was not; ``progress(done,
        run_dir)`` after each."""
        out: dict[Path, str | None] = {}
        try:
            for done, run_dir in enumerate(self.run_dirs, 1):
                if self.executor is None:
                    out[run_dir] = write_report(str(run_dir))
                else:
                    try:
                        out[run_dir] = self.futures[done - 1].result()
                    except BrokenProcessPool:  # killed (out of memory?) or crashed
                        out[run_dir] = "the process writing its report died"
                if progress is not None:
                    progress(done, run_dir)
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
            from etsid.batch.local import _stop

            _stop(self.executor)
        else:
            self.executor.shutdown(wait=True)
        self.executor = None
