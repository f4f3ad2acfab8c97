"""Concurrent ``--resume`` batches work each log once; a killed batch's staging folders are
removed by the next ``--resume`` (etsid/batch/locks.py)."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pandas as pd

from etsid.batch.locks import log_lock, remove_stale_staging


def _batch(out: Path, *inputs: Path, resume: bool = True) -> subprocess.Popen:
    args = [sys.executable, "-m", "etsid", "batch", "ingest", *map(str, inputs), "-o",
            str(out), "-j", "1", "-q", *(["--resume"] if resume else [])]
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "ETSID_PROGRESS": "off"})


def test_two_concurrent_resumes_work_each_log_once(fleet: Path, tmp_path: Path) -> None:
    logs = [fleet / "a.tlog", fleet / "d.mcap", fleet / "sub" / "b.bag"]
    out = tmp_path / "B"
    first, second = _batch(out, *logs), _batch(out, *logs)
    worked = 0
    for proc in (first, second):
        printed, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err
        worked += int(re.search(r"(\d+) ok", printed + err).group(1))
    assert worked == len(logs), f"{worked} logs worked for {len(logs)}: some twice"
    rows = pd.read_parquet(out / "results")
    ok = rows[rows["status"] == "ok"]
    # every log has exactly one row: the other batch skipped it (at its start or after
    # waiting for the log's lock), never worked it a second time
    assert sorted(ok["input"]) == sorted(map(str, logs))
    meta = json.loads((out / "batch.json").read_text())
    assert meta["resume"] is True


def test_a_waiting_worker_sees_the_lock_held(tmp_path: Path) -> None:
    final = tmp_path / "runs" / "ingest-0" / "x-0123456789ab"
    holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import time
        from pathlib import Path
        from etsid.batch.locks import log_lock
        with log_lock(Path({str(final)!r})):
            print("held", flush=True)
            time.sleep(1.5)
        """)], stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "held"
    start = time.monotonic()
    with log_lock(final) as waited:
        assert waited and time.monotonic() - start > 0.5
    holder.wait(timeout=30)
    with log_lock(final) as waited:  # free now: no wait
        assert not waited


def test_resume_removes_a_killed_workers_staging(fleet: Path, tmp_path: Path) -> None:
    out = tmp_path / "B"
    first = _batch(out, fleet / "a.tlog", resume=False)
    assert first.wait(timeout=600) == 0
    group = next((out / "runs").iterdir())
    final = group / "killed-0123456789ab"
    worker = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import os, signal
        from pathlib import Path
        from etsid.batch.worker import staged_dir
        with staged_dir(Path({str(final)!r})) as staging:
            (staging / "table.parquet").write_bytes(b"PAR1 partial")
            print(staging, flush=True)
            os.kill(os.getpid(), signal.SIGKILL)
        """)], stdout=subprocess.PIPE, text=True)
    staging = Path(worker.stdout.readline().strip())
    assert worker.wait(timeout=30) == -signal.SIGKILL
    assert staging.is_dir() and staging.name.startswith(".killed-")  # what SIGKILL leaves
    resumed = _batch(out, fleet / "a.tlog")
    assert resumed.wait(timeout=600) == 0
    assert json.loads((out / "batch.json").read_text())["stale_staging_removed"] == 1
    assert not staging.exists()
    held = group / "busy-0123456789ab"
    busy = group / f".{held.name}.abcd1234"
    busy.mkdir()
    with log_lock(held):  # a live worker's staging is kept
        assert remove_stale_staging(out / "runs") == 0
    assert busy.is_dir()
    assert remove_stale_staging(out / "runs") == 1 and not busy.exists()
