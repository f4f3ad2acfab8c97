"""Several run reports at once (the fleet report's best and worst flights).

A run's report is one to two seconds of matplotlib and Bokeh work for one core; the fleet
report writes up to ten of them. It hands them to a :data:`Runner`: by default
:class:`InProcess` (one after the other, when the results are asked for); ``etsid report``
gives :class:`etsid.batch.pool.WarmPool`, which starts them at once in worker processes
forked from a server that has imported :data:`PRELOAD`, while the fleet's own page is
drawn.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol

from etsid.errors import EtsidError

PRELOAD = ("etsid.report.build", "etsid.report.run_plots", "etsid.report.interactive",
           "etsid.report.overview", "bokeh.plotting", "bokeh.embed",
           "matplotlib.backends.backend_agg")
"""Modules a worker process needs imported before its first run report."""


class Pending(Protocol):
    """Work started by a :data:`Runner`."""

    def results(self, progress: Callable[[int, Any], None] | None = None) -> list[Any]:
        """Each item's result, in order (an exception instance for an item whose worker
        process died); ``progress(done, item)`` after each."""

    def close(self, cancel: bool = False) -> None:
        """Stop what is left (``cancel``) or wait for it."""


Runner = Callable[[Callable[[Any], Any], Sequence[Any], Sequence[str]], Pending]
"""Starts ``func`` over ``items`` (a worker process imports the modules named first)."""


class InProcess:
    """The :data:`Runner` of no worker processes: :meth:`results` runs every item here."""

    def __init__(self, func: Callable[[Any], Any], items: Sequence[Any],
                 preload: Sequence[str] = ()) -> None:
        self.func, self.items = func, list(items)

    def results(self, progress: Callable[[int, Any], None] | None = None) -> list[Any]:
        out = []
        for done, item in enumerate(self.items, 1):
            out.append(self.func(item))
            if progress is not None:
                progress(done, item)
        return out

    def close(self, cancel: bool = False) -> None:
        """Nothing runs in the background."""


def write_report(run_dir: str) -> str | None:
    """Write ``run_dir``'s report: None, or the one-line reason it failed (an
    :class:`~etsid.errors.EtsidError`: not a run directory, unreadable files)."""
    from etsid.report.build import make_report

    try:
        make_report(run_dir)
    except EtsidError as err:
        return str(err)
    return None
