"""Per-log locks and the staging folders a killed batch leaves behind.

A log's run directory ``runs/CMD-DIGEST/NAME-KEY`` is written into a hidden staging folder
``.NAME-KEY.XXXX`` beside it and renamed into place whole (etsid/batch/worker.py). Two
batches started with ``--resume`` on one folder, or a batch killed with SIGKILL, need two
more things, both here:

- :func:`log_lock`: an exclusive ``flock`` on ``.NAME-KEY.lock`` held while a log is worked
  on (the holder removes the file when it lets go); a second batch that reaches the same
  log waits for it, and skips it when another batch put its run directory in place since
  the second one started
  (:func:`done_elsewhere`): no log is worked twice;
- :func:`remove_stale_staging`: staging folders whose lock nobody holds are what a killed
  worker left (partial Parquet files); ``--resume`` removes them.

Without ``fcntl`` (Windows) there are no locks: logs may then be worked twice, never mixed.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import IO

RESUMING = "resuming:"
"""Prefix of a marker put in the ``done`` keys of a ``--resume`` batch (never a 32-hex key),
followed by the batch's start time: a log whose run directory another batch put in place
after that time is skipped (:func:`done_elsewhere`)."""


def resume_marker(started: float) -> str:
    """The marker of a ``--resume`` batch started at ``started`` (``time.time()``)."""
    return f"{RESUMING}{started!r}"


def done_elsewhere(final: Path, done: frozenset[str]) -> bool:
    """True when this is a ``--resume`` batch and another batch put run directory
    ``final`` in place since this one began to read its results (checked while holding the
    log's lock; a worker stamps a run directory with the time it put it in place). A log
    put in place before that moment whose row is not in the results yet is still worked
    again: the window is the other batch's time from the rename to its row."""
    starts = [float(k[len(RESUMING):]) for k in done if k.startswith(RESUMING)]
    if not starts:
        return False
    try:
        return final.is_dir() and final.stat().st_mtime >= starts[0]
    except OSError:
        return False


STAGING = re.compile(r"^\.(?P<final>.+-[0-9a-f]{12})\.(old\.)?[^.]+$")
"""A staging folder of run directory ``final`` (``tempfile.mkdtemp`` suffix)."""


def lock_path(final: Path) -> Path:
    """The lock file of run directory ``final``."""
    return final.parent / f".{final.name}.lock"


def _acquire(path: Path, wait: bool) -> tuple[IO[str], bool] | None:
    """Open and ``flock`` lock file ``path``; returns the handle and whether it had to wait,
    or None when ``wait`` is False and another process holds it. The holder removes the file
    on release (no lock files are left behind), so a lock taken on a file that was meanwhile
    removed or replaced is dropped and taken again on the current one."""
    import fcntl

    waited = False
    while True:
        handle = open(path, "a")  # noqa: SIM115 - held until release
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            if not wait:
                handle.close()
                return None
            waited = True
            fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            current = os.stat(path).st_ino == os.fstat(handle.fileno()).st_ino
        except FileNotFoundError:
            current = False
        if current:
            return handle, waited
        handle.close()


def _release(path: Path, handle: IO[str]) -> None:
    """Remove lock file ``path`` while holding it, then let it go."""
    import fcntl

    with contextlib.suppress(FileNotFoundError):
        path.unlink()
    fcntl.flock(handle, fcntl.LOCK_UN)
    handle.close()


@contextlib.contextmanager
def log_lock(final: Path) -> Iterator[bool]:
    """Hold the lock of run directory ``final``; yields True when another process held it
    and this one had to wait (it may have finished the log meanwhile)."""
    try:
        import fcntl  # noqa: F401 - POSIX only
    except ImportError:  # pragma: no cover - not on POSIX
        yield False
        return
    final.parent.mkdir(parents=True, exist_ok=True)
    path = lock_path(final)
    taken = _acquire(path, wait=True)
    assert taken is not None
    handle, waited = taken
    try:
        yield waited
    finally:
        _release(path, handle)


def remove_stale_staging(runs: Path) -> int:
    """Remove the staging folders below ``runs/*/`` that no running batch holds the lock
    of; returns how many were removed."""
    try:
        import fcntl  # noqa: F401 - POSIX only
    except ImportError:  # pragma: no cover - not on POSIX
        return 0
    removed = 0
    if not runs.is_dir():
        return 0
    for group in sorted(p for p in runs.iterdir() if p.is_dir() and not p.is_symlink()):
        for item in sorted(group.iterdir()):
            match = STAGING.match(item.name)
            if not match or not item.is_dir() or item.is_symlink():
                continue
            path = lock_path(group / match["final"])
            taken = _acquire(path, wait=False)
            if taken is None:
                continue  # a live worker is writing it
            try:
                shutil.rmtree(item, ignore_errors=True)
                removed += not item.exists()
            finally:
                _release(path, taken[0])
    return removed
