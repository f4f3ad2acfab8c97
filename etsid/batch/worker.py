"""One log of a batch, start to finish: fetch, hash, skip or run, and a result row.

:func:`run_log` never raises for a bad log: any error becomes the row's one-line ``error``
(a :class:`KeyboardInterrupt` still stops it). It runs the same in the parent
(``--jobs 1``), in a process of the local pool, and on a Dask worker.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import errno
import hashlib
import os
import resource
import shutil
import signal
import socket
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from etsid import __version__
from etsid.batch import tasks
from etsid.batch.fetch import local_copy
from etsid.batch.inputs import run_name
from etsid.batch.lifeline import die_with_parent
from etsid.batch.locks import done_elsewhere, log_lock
from etsid.batch.results import RUNS, write_row
from etsid.batch.spec import BatchSpec
from etsid.errors import EtsidError
from etsid.ident.rundir import os_errno, os_reason, sha256

Item = str | tuple[str, str]
"""A log (path or URL), or for ``gap`` a ``(sim, real)`` pair."""


@dataclass
class Outcome:
    """What one log gave: its row, or ``row=None`` when ``--resume`` skipped it; a pool
    worker adds its process id and resident memory after the log (MB). ``written``: the
    worker wrote the row file itself (Dask), and ``row`` keeps only the fields the
    summary needs."""

    item: Item
    key: str | None
    row: dict[str, Any] | None
    pid: int | None = None
    rss_mb: float | None = None
    written: bool = False


def reset_peak_memory() -> None:
    """Start a new peak-RSS measurement (Linux: clears VmHWM; elsewhere a no-op)."""
    with contextlib.suppress(OSError), open("/proc/self/clear_refs", "w") as handle:
        handle.write("5")


def peak_memory_mb() -> float:
    """Peak resident memory of this process since :func:`reset_peak_memory`, MB."""
    with contextlib.suppress(OSError, ValueError, IndexError), \
            open("/proc/self/status") as handle:
        for line in handle:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def one_line(err: BaseException) -> str:
    """The first line of an error message (the class name for an empty one)."""
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


class WorkerDied(Exception):
    """The process running a log died (killed by the system, or crashed) every time the log
    was tried: the local pool after running it alone, Dask after its retries."""

    def __str__(self) -> str:
        return ("worker process died while reading this log (killed by the system, "
                "probably out of memory, or crashed)")


def error_fields(err: BaseException) -> dict[str, Any]:
    """``status``/``error``/``error_kind`` of a failed log."""
    if isinstance(err, WorkerDied):
        text = str(err)
    elif isinstance(err, MemoryError):
        text = one_line(err) if str(err).startswith("out of memory") else (
            "out of memory (give the worker more memory)")
    elif isinstance(err, EtsidError):
        text = one_line(err)
    elif isinstance(err, OSError) and os_errno(err) in (errno.ENOSPC, errno.EDQUOT):
        text = f"cannot write the run directory ({os_reason(err)})"
    else:
        text = f"internal error: {type(err).__name__}: {one_line(err)}"
    return {"status": "error", "error": text, "error_kind": type(err).__name__}


def failed_outcome(item: Item, spec: BatchSpec, err: BaseException) -> Outcome:
    """The row of a log whose worker could not return one (it died, or the scheduler lost
    the task): no hash, since the parent never opens a log."""
    row = {"input": item[1] if isinstance(item, tuple) else item,
           "sim_input": item[0] if isinstance(item, tuple) else None,
           "options_digest": spec.digest(), **error_fields(err)}
    return Outcome(item, None, row)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def staged_dir(final: Path) -> Iterator[Path]:
    """A private staging folder beside ``final`` that becomes ``final`` whole when the
    block ends without error (an earlier ``final`` is replaced only then), and is removed
    otherwise: a log that fails, a full disk or a killed worker never leave half a run
    directory, and two workers finishing the same log never mix their files."""
    final.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{final.name}.", dir=final.parent))
    try:
        yield staging
        staging.chmod(0o777 & ~_umask())  # mkdtemp makes 0700
        for attempt in range(3):  # another worker may put the same log in place meanwhile
            old = None
            try:
                if final.exists():
                    old = Path(tempfile.mkdtemp(prefix=f".{final.name}.old.",
                                                dir=final.parent))
                    os.replace(final, old / final.name)
                os.rename(staging, final)
                os.utime(final)  # its time is when it was put in place, not its last file's
                break
            except OSError:
                if attempt == 2:
                    raise
            finally:
                if old is not None:
                    shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _run(item: Item, spec: BatchSpec, out: Path, digest: str, done: frozenset[str],
         row: dict[str, Any]) -> bool:
    """Fill ``row`` for one log (hash and run directory first, so that they stay in an
    error row); False when the log is in ``done`` (skipped)."""
    with contextlib.ExitStack() as stack:
        if isinstance(item, tuple):
            sim = stack.enter_context(local_copy(item[0], spec.protocols))
            real = stack.enter_context(local_copy(item[1], spec.protocols))
            row.update(sim_sha256=sha256(sim), input_sha256=sha256(real))
            key = hashlib.sha256(f"{row['sim_sha256']}:{row['input_sha256']}".encode())
            row["_key"] = key.hexdigest()
            if row["_key"][:32] in done:
                return False
            run_dir = out / RUNS / f"gap-{digest[:8]}" / f"{run_name(item[1])}-{row['_key'][:12]}"
            row["run_dir"] = run_dir.relative_to(out).as_posix()
            with log_lock(run_dir):
                if done_elsewhere(run_dir, done):
                    return False  # another batch did this log since this one started
                with staged_dir(run_dir) as staging:
                    row.update(tasks.gap(sim, real, spec, staging))
            return True
        path = stack.enter_context(local_copy(item, spec.protocols))
        row["_local"] = str(path)
        row["input_sha256"] = row["_key"] = sha256(path)
        if row["_key"][:32] in done:
            return False
        name = f"{run_name(item)}-{row['_key'][:12]}"
        run_dir = out / RUNS / f"{spec.command}-{digest[:8]}" / name
        row["run_dir"] = run_dir.relative_to(out).as_posix()
        with log_lock(run_dir):
            if done_elsewhere(run_dir, done):
                return False  # another batch did this log since this one started
            with staged_dir(run_dir) as staging:
                row.update(tasks.RUNNERS[spec.command](path, spec, staging))
        return True


def run_log(item: Item, spec: BatchSpec, out: str | Path,
            done: frozenset[str] = frozenset()) -> Outcome:
    """Run ``spec.command`` on one log (or pair) and return its :class:`Outcome`.

    Parameters
    ----------
    item
        A path or URL; for ``gap`` a ``(sim, real)`` pair.
    out
        The batch directory (run directories go to ``out/runs/``).
    done
        Result keys (first 32 hex digits of the input hash) already in the results for
        this options digest; such a log is skipped.
    """
    out = Path(out)
    digest = spec.digest()
    start = time.perf_counter()
    cpu = time.process_time()
    reset_peak_memory()
    row: dict[str, Any] = {"input": item[1] if isinstance(item, tuple) else item,
                           "sim_input": item[0] if isinstance(item, tuple) else None,
                           "options_digest": digest, "status": "ok"}
    try:
        if not _run(item, spec, out, digest, done, row):
            return Outcome(item, row.get("_key"), None)
    except Exception as err:  # one bad log never stops the batch: it becomes a row
        row.update(error_fields(err))
        if row.get("_local") and row["_local"] != item:  # name the URL, not the copy
            row["error"] = row["error"].replace(row["_local"], str(item))
    row.pop("_local", None)
    key = row.pop("_key", None)
    row.update(wall_s=time.perf_counter() - start, cpu_s=time.process_time() - cpu,
               peak_rss_mb=peak_memory_mb(),
               worker=f"{socket.gethostname()}:{os.getpid()}", etsid_version=__version__,
               finished=dt.datetime.now(dt.UTC).isoformat(timespec="seconds"))
    return Outcome(item, key, row)


SUMMARY_FIELDS = ("input", "sim_input", "status", "error", "error_kind")
"""Row fields a Dask worker sends back once it has written the row itself."""


def run_and_write(item: Item, spec: BatchSpec, out: str | Path,
                  done: frozenset[str] = frozenset()) -> Outcome:
    """:func:`run_log`, then the row written here (a Dask worker): only the fields of
    :data:`SUMMARY_FIELDS` go back to the client.

    Raises
    ------
    BatchError
        The row could not be written (a full disk): the batch stops.
    """
    outcome = run_log(item, spec, out, done)
    if outcome.row is not None:
        write_row(out, spec.command, outcome.row, outcome.key)
        outcome.row = {name: outcome.row.get(name) for name in SUMMARY_FIELDS}
        outcome.written = True
    return outcome


# -- process-pool workers: the batch's fixed arguments are set once per process ----------

_STATE: dict[str, Any] = {}


def _rss_mb() -> float | None:
    with contextlib.suppress(OSError, ValueError, IndexError), \
            open("/proc/self/statm") as handle:
        return int(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    return None


def _over_limit(signum: int, frame: Any) -> None:
    raise MemoryError(f"out of memory: the log needed more than --max-memory "
                      f"{_STATE['max_memory_mb']:g} MB")


def _watch_memory(limit_mb: float, period_s: float = 0.05) -> None:
    """Thread body: when this process's RSS passes ``limit_mb``, interrupt the main thread
    with a MemoryError (at its next Python instruction)."""
    main = threading.main_thread().ident
    fired = None
    while True:
        time.sleep(period_s)
        running = _STATE.get("running")
        if running is None or running == fired or main is None:
            continue
        rss = _rss_mb()
        if rss is not None and rss > limit_mb:
            fired = running  # once per log
            signal.pthread_kill(main, signal.SIGUSR1)


def init_worker(spec: BatchSpec, out: str, done: frozenset[str],
                max_memory_mb: float | None) -> None:
    """Initializer of a pool process: ignore Ctrl-C (the parent stops the pool), die with
    the parent, watch the memory when asked, import the command's modules, keep the batch
    arguments."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent()  # the fork server (or, spawned, the batch process)
    for name in tasks.PRELOAD:
        __import__(name)
    _STATE.update(spec=spec, out=out, done=done, max_memory_mb=max_memory_mb)
    if max_memory_mb and _rss_mb() is not None:
        signal.signal(signal.SIGUSR1, _over_limit)
        threading.Thread(target=_watch_memory, args=(max_memory_mb,), daemon=True).start()


def run_pooled(item: Item) -> Outcome:
    """:func:`run_log` with the arguments :func:`init_worker` kept."""
    _STATE["running"] = _STATE.get("count", 0) + 1
    _STATE["count"] = _STATE["running"]
    try:
        outcome = run_log(item, _STATE["spec"], _STATE["out"], _STATE["done"])
    finally:
        _STATE["running"] = None
    outcome.pid = os.getpid()
    outcome.rss_mb = _rss_mb()
    return outcome
