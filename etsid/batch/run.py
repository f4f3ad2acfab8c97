"""``etsid batch``: run one command over many logs, a result row per log.

Every log runs independently, with the same options, in its own run directory
``DIR/runs/COMMAND-DIGEST/NAME-HASH/``; its row lands in ``DIR/results/`` the moment it
finishes. ``DIR/batch.json`` records the command, the options and how the batch ended.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import json
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from etsid.batch.locks import remove_stale_staging, resume_marker
from etsid.batch.results import RUNS, compact, done_keys, write_row
from etsid.batch.spec import COMMANDS, BatchSpec
from etsid.batch.tasks import GAP_UNAVAILABLE, gap_available
from etsid.batch.worker import Item, Outcome
from etsid.errors import BatchError
from etsid.ident.rundir import os_reason
from etsid.progress import progress

EXIT_ALL_FAILED = 3
"""Exit code of ``etsid batch`` when no log of the batch succeeded (every row an error).
Others: 0 at least one log ok (the failed ones are listed), 1 nothing run (an input that
does not exist, no log found, a bad option: one line, no batch directory left behind),
2 a usage error (click)."""

SCHEDULERS = ("local", "processes")
"""``--scheduler`` names; anything else is a Dask scheduler address (``dask://HOST:PORT``)."""


@dataclass
class BatchSummary:
    """How a batch went: counts, wall time and the failed logs with their errors."""

    out: Path
    total: int = 0
    ok: int = 0
    failed: int = 0
    skipped: int = 0
    wall_s: float = 0.0
    failures: list[tuple[str, str]] = field(default_factory=list)


def default_jobs() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def _runner(spec: BatchSpec, out: Path, done: frozenset[str], jobs: int, scheduler: str,
            max_memory_mb: float | None, dashboard: str | None) -> Any:
    if scheduler == "local":
        from etsid.batch.local import LocalRunner

        return LocalRunner(spec, out, done, jobs, max_memory_mb)
    from etsid.batch.cluster import DaskRunner, scheduler_address

    if scheduler != "processes" and "://" not in scheduler:
        raise BatchError(f"--scheduler {scheduler!r}: use local, processes or "
                         "dask://HOST:PORT")
    return DaskRunner(spec, out, done, jobs, scheduler_address(scheduler), dashboard)


def _write_meta(out: Path, data: dict[str, Any]) -> None:
    """``DIR/batch.json``, whole (a unique temporary file, then a rename)."""
    path = out / "batch.json"
    tmp: Path | None = None
    try:
        handle, name = tempfile.mkstemp(prefix=".batch.json.", suffix=".tmp", dir=out)
        tmp = Path(name)
        with os.fdopen(handle, "w") as stream:
            stream.write(json.dumps(data, indent=1, default=str) + "\n")
        os.replace(tmp, path)
    except OSError as err:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        raise BatchError(f"{path}: cannot write ({os_reason(err)})") from err


def run_batch(items: list[Item], spec: BatchSpec, out: str | Path, jobs: int | None = None,
              scheduler: str = "local", resume: bool = False, show_progress: bool = False,
              max_memory_mb: float | None = None, retry_failed: bool = True,
              dashboard: str | None = None) -> BatchSummary:
    """Run ``spec.command`` on every item and write a result row per item.

    Parameters
    ----------
    items
        Logs (paths or URLs; :func:`etsid.batch.find_inputs`), or ``(sim, real)`` pairs
        for ``gap`` (:func:`etsid.batch.read_pairs`).
    out
        Batch directory (created); rows go to ``out/results/``.
    jobs
        Worker processes (default: every core).
    scheduler
        ``local`` (a process pool here), ``processes`` (a Dask LocalCluster here) or a
        Dask scheduler address ``dask://HOST:PORT``.
    resume
        Skip every log with an ``ok`` row for the same input hash and options.
    retry_failed
        With ``resume``, run the logs with an error row again (False: skip them too,
        ``--skip-failed``).
    show_progress
        Progress bar over logs on stderr.
    max_memory_mb
        Memory (RSS) limit of each local pool worker, MB (None: no limit); a log that
        passes it becomes a MemoryError row.
    dashboard
        ``--scheduler processes``: address of Dask's dashboard, e.g. ``127.0.0.1:8787``
        (None: no dashboard; the cluster listens on 127.0.0.1 only either way).

    Raises
    ------
    BatchError
        Unknown command or scheduler, no inputs, gap analysis not available.
    KeyboardInterrupt
        Ctrl-C: workers stopped; the rows written so far stay, ``--resume`` continues.
    """
    if spec.command not in COMMANDS:
        raise BatchError(f"unknown batch command {spec.command!r}")
    if spec.command == "gap" and not gap_available():
        raise BatchError(GAP_UNAVAILABLE)
    if not items:
        raise BatchError("no logs to run: the inputs hold no file of a supported format")
    out = Path(out)
    made = _new_dirs(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise BatchError(f"{out}: cannot create the batch directory ({err.strerror})") from err
    jobs = max(1, jobs or default_jobs())
    digest = spec.digest()
    stale = 0
    try:
        scanned = time.time()  # before the results are read: a log another batch puts
        # in place from now on may be missing from them, and is skipped by its time
        done = done_keys(out, spec.command, digest, retry_failed) if resume else frozenset()
        if resume:  # a killed batch's staging folders (partial files), and the marker that
            # lets a worker skip a log another --resume batch finished while it waited
            stale = remove_stale_staging(out / RUNS)
            done = done | {resume_marker(scanned)}
        runner = _runner(spec, out, done, jobs, scheduler, max_memory_mb, dashboard)
    except BaseException:
        _remove_empty(made)  # an error before any log ran leaves no empty folder
        raise
    summary = BatchSummary(out, total=len(items))
    meta: dict[str, Any] = {
        "schema": "etsid.batch/1", "command": spec.command, "options_digest": digest,
        "options": spec.options(), "inputs": len(items), "jobs": jobs,
        "scheduler": scheduler, "resume": resume,
        "retry_failed": retry_failed, "stale_staging_removed": stale,
        "started": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
    }
    _write_meta(out, meta)
    start = time.perf_counter()
    running = 0
    with progress(len(items), f"{spec.command} logs", show_progress) as bar:

        def status() -> str:
            return (f"ok {summary.ok} · failed {summary.failed} · running {running}"
                    + (f" · skipped {summary.skipped}" if summary.skipped else ""))

        def on_running(n: int) -> None:
            nonlocal running
            if n != running:
                running = n
                bar.update(0, status())

        def on_done(outcome: Outcome) -> None:
            if outcome.row is None:
                summary.skipped += 1
            else:
                if not outcome.written:
                    write_row(out, spec.command, outcome.row, outcome.key)
                if outcome.row["status"] == "ok":
                    summary.ok += 1
                else:
                    summary.failed += 1
                    summary.failures.append((outcome.row["input"], outcome.row["error"]))
            bar.update(1, status())

        try:
            runner.run(items, on_done, on_running)
        except BaseException as err:
            meta.update(ended="interrupted" if isinstance(err, KeyboardInterrupt)
                        else "failed", **_counts(summary, start))
            with contextlib.suppress(BatchError):  # a full disk: the error says so
                _write_meta(out, meta)
            raise
    compact(out, spec.command)
    summary.wall_s = time.perf_counter() - start
    meta.update(ended="finished", **_counts(summary, start))
    timings = getattr(runner, "timings", None)
    if timings:
        meta["dask_timings_s"] = {k: round(v, 3) for k, v in timings.items()}
    _write_meta(out, meta)
    return summary


def _new_dirs(out: Path) -> list[Path]:
    """The folders ``out.mkdir(parents=True)`` would create, deepest first."""
    made: list[Path] = []
    path = out.absolute()
    while not path.exists() and path != path.parent:
        made.append(path)
        path = path.parent
    return made


def _remove_empty(made: list[Path]) -> None:
    """Remove the folders of :func:`_new_dirs` that are still empty."""
    for path in made:
        with contextlib.suppress(OSError):
            path.rmdir()


def _counts(summary: BatchSummary, start: float) -> dict[str, Any]:
    return {"ok": summary.ok, "failed": summary.failed, "skipped": summary.skipped,
            "wall_s": round(time.perf_counter() - start, 3),
            "finished": dt.datetime.now(dt.UTC).isoformat(timespec="seconds")}
