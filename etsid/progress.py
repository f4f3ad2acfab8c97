"""Progress on stderr: what a command is doing while it works.

On a terminal, a bar (:func:`progress`, for work of known size) or a transient status line
(:func:`say`, :func:`stage`) that the next one replaces. When stderr is not a terminal (a CI
log, ``| tee``), plain lines: a step is said once it has run :data:`DELAY_S` seconds, or
once nothing has been said for that long (a run of short steps), then again every
:data:`EVERY_S` seconds with its elapsed time. Short work stays silent; while any step runs,
the log is never silent for much longer than two seconds (the watcher's tick, and a C call
that holds the interpreter lock, can add a little).

Library calls are silent: the ``etsid`` command turns progress on (:func:`enable`) for the
command it runs; ``--quiet`` turns it off again, and so does ``ETSID_PROGRESS=off`` in the
environment (the test suite sets it: lines that depend on how long a step takes would make
tests of exact output depend on the machine's load; tests/test_progress.py turns it on).

>>> enabled()
False
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

import click

DELAY_S = 2.0
"""A step still running after this long (s) says what it is doing when not on a terminal."""
EVERY_S = 2.0
"""Then it says so again this often (s): the issue's "no silent stretch over 2 s"."""
FRESH_S = 5.0
"""A process younger than this (s) when etsid.progress is imported is a command starting:
its silence counts from the process's start; an older one (a notebook, a test runner) from
the import."""
TICK_S = 0.25
"""How often the watcher thread looks at the current step (s)."""

_state = {"on": False, "jit": False}


def enable(on: bool = True) -> None:
    """Turn progress output on (the CLI does, per command) or off (``--quiet``)."""
    _state["on"] = on
    if not on:
        NARRATOR.done()


def enabled() -> bool:
    """True when progress output is on."""
    return _state["on"]


def wanted(quiet: bool = False) -> bool:
    """True when progress should be shown: on (:func:`enable`) and not ``--quiet``.

    A ``--quiet`` command also silences :func:`say` and :func:`stage`.
    """
    if quiet:
        enable(False)
    return enabled()


def on_terminal() -> bool:
    """True when stderr is a terminal (bars and transient lines), else plain lines."""
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


def _process_start() -> float:
    """When this process started, on :func:`time.monotonic`'s clock (Linux: from
    ``/proc/self/stat``, the boot-time clock and the clock tick; elsewhere: now). The
    interpreter's start-up and the imports before the first step count as silence too."""
    try:
        with open("/proc/self/stat", "rb") as handle:
            fields = handle.read().rsplit(b")", 1)[1].split()
        started = int(fields[19]) / os.sysconf("SC_CLK_TCK")  # s since boot (field 22)
        age = time.clock_gettime(time.CLOCK_BOOTTIME) - started
    except (OSError, ValueError, IndexError, AttributeError):
        return time.monotonic()
    if not 0.0 <= age <= FRESH_S:  # imported by a running program, not at a command's start
        return time.monotonic()
    return time.monotonic() - age


def _early(limit_s: float) -> float:
    """When the watcher says a line so that none comes later than ``limit_s``: a tick early
    (it looks only every :data:`TICK_S`), for limits several ticks long."""
    return limit_s - TICK_S if limit_s >= 4 * TICK_S else limit_s


class Narrator:
    """The current step of a command, said on stderr (see the module docstring).

    Parameters
    ----------
    delay_s, every_s
        Seconds before a step is first said when not on a terminal, and between repeats.
    """

    def __init__(self, delay_s: float = DELAY_S, every_s: float = EVERY_S) -> None:
        self.delay_s, self.every_s = delay_s, every_s
        self._lock = threading.Lock()
        self._label: str | None = None
        self._outer: list[str] = []  # labels of the enclosing steps (:meth:`push`)
        self._start = 0.0
        self._said_at: float | None = None
        self._last_line = time.monotonic()  # when this narrator last printed a line
        self._thread: threading.Thread | None = None
        self._stream: TextIO | None = None
        self._terminal = False

    @property
    def current(self) -> str | None:
        """The step being said now (None: none)."""
        return self._label

    def say(self, label: str, restart: bool = True) -> None:
        """``label`` is what is being done now; ``restart=False`` keeps the step's clock
        (a new percentage of the same step)."""
        if not enabled():
            return
        if not _state.get("jit") and "numba" in sys.modules:
            from etsid import jitnote  # a numba compile on a cold cache says so

            _state["jit"] = jitnote.install(NARRATOR, enabled)
        with self._lock:
            self._stream = sys.stderr
            self._terminal = on_terminal()
            if restart or self._label is None:
                self._start, self._said_at = time.monotonic(), None
            self._label = label
            if self._terminal:
                click.echo(f"\r\033[K{label}", file=self._stream, nl=False)
                return
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(target=self._watch, name="etsid-progress",
                                                daemon=True)
                self._thread.start()

    def done(self) -> None:
        """The step is over, and every step around it (a transient line is cleared)."""
        with self._lock:
            if self._label is not None and self._terminal and self._stream is not None:
                click.echo("\r\033[K", file=self._stream, nl=False)
            self._label = None
            self._outer.clear()

    def push(self, label: str, at_once: bool = False) -> None:
        """A step inside the current one (a bar inside "reading …"); :meth:`pop` ends it.

        ``at_once``: when not on a terminal, say it now rather than after ``delay_s`` (a
        step known to be long, such as a numba compile); repeats follow every ``every_s``.
        """
        if not enabled():
            return
        with self._lock:
            if self._label is not None:
                self._outer.append(self._label)
        self.say(label)
        if at_once and not self._terminal:
            with self._lock:
                self._said_at = self._last_line = time.monotonic()
                click.echo(f"{label.rstrip(' …')} …", file=self._stream)

    def pop(self) -> None:
        """End the innermost step; the step around it, if any, is said again from now."""
        with self._lock:
            outer = self._outer.pop() if self._outer else None
        if outer is None:
            self.done()
        else:
            self.say(outer)

    def _watch(self) -> None:
        while True:
            time.sleep(TICK_S)
            with self._lock:
                if self._label is None or self._stream is None:
                    continue
                now = time.monotonic()
                elapsed = now - self._start
                base = self._label.rstrip(" …")
                quiet_s = now - self._last_line
                # a tick early, so that no stretch without a line exceeds delay_s / every_s
                if self._said_at is None and max(elapsed, quiet_s) >= _early(self.delay_s):
                    line = f"{base} …"
                elif self._said_at is not None and now - self._said_at >= _early(self.every_s):
                    line = f"{base} … ({elapsed:.0f} s)"
                else:
                    continue
                self._said_at = self._last_line = now
                try:
                    click.echo(line, file=self._stream)
                except (OSError, ValueError):  # stream closed (a test runner's capture)
                    self._label = None


NARRATOR = Narrator()
NARRATOR._last_line = _process_start()  # a command's silence counts from its start


def say(label: str) -> None:
    """Say that ``label`` is what the command does now (replaces the previous step)."""
    NARRATOR.say(label)


def done() -> None:
    """The current step is over."""
    NARRATOR.done()


@contextmanager
def stage(label: str) -> Iterator[None]:
    """Say ``label`` for the duration of the ``with`` block (inside another step: that
    step is said again after it)."""
    NARRATOR.push(label)
    try:
        yield
    finally:
        NARRATOR.pop()


class Progress:
    """Advance by ``update(n)``; a no-op object when disabled."""

    def __init__(self, bar: object | None, label: str = "", total: int = 0) -> None:
        self._bar = bar
        self._label, self._total, self._done = label, total, 0

    def update(self, n: int, status: str | None = None) -> None:
        """Advance by ``n`` units; ``status`` replaces the text after the bar."""
        if self._bar is not None and (n or status is not None):
            self._bar.update(n, current_item=status)  # type: ignore[attr-defined]
        elif self._total > 0 and (n or status is not None):
            self._done += n
            pct = 100.0 * self._done / self._total
            NARRATOR.say(f"{self._label}: {pct:.0f} % ({self._done}/{self._total})"
                         + (f", {status}" if status else ""), restart=False)


@contextmanager
def progress(total: int, label: str, enabled: bool) -> Iterator[Progress]:
    """A :class:`Progress` of ``total`` units (e.g. bytes, samples): a bar on a terminal,
    plain percentage lines otherwise (:class:`Narrator`), nothing when not ``enabled``."""
    if not enabled or total <= 0 or not _state["on"]:
        yield Progress(None)
        return
    if not on_terminal():
        NARRATOR.push(f"{label}: 0 % (0/{total})")
        try:
            yield Progress(None, label, total)
        finally:
            NARRATOR.pop()
        return
    with click.progressbar(length=total, label=label, file=sys.stderr,
                           show_eta=True, show_percent=True,
                           item_show_func=lambda status: status) as bar:
        yield Progress(bar)
