"""A progress bar on stderr that goes silent when stderr is not a terminal."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager

import click


def wanted(quiet: bool = False) -> bool:
    """True when a progress bar should be drawn: stderr is a TTY and not ``--quiet``."""
    return not quiet and sys.stderr.isatty()


class Progress:
    """Advance by ``update(n)``; a no-op object when disabled."""

    def __init__(self, bar: object | None) -> None:
        self._bar = bar

    def update(self, n: int, status: str | None = None) -> None:
        """Advance the bar by ``n`` units; ``status`` replaces the text after the bar."""
        if self._bar is not None and (n or status is not None):
            self._bar.update(n, current_item=status)  # type: ignore[attr-defined]


@contextmanager
def progress(total: int, label: str, enabled: bool) -> Iterator[Progress]:
    """Context manager yielding a :class:`Progress` of ``total`` units (e.g. bytes, samples)."""
    if not enabled or total <= 0:
        yield Progress(None)
        return
    with click.progressbar(length=total, label=label, file=sys.stderr,
                           show_eta=True, show_percent=True,
                           item_show_func=lambda status: status) as bar:
        yield Progress(bar)
