"""Workers that die or outgrow their memory cost the batch one row at most: the culprit's.

A worker that dies (SIGKILL, as the kernel's OOM killer sends it) is replaced, and the log
it was running is retried; only a log that kills every worker it is given to gets the row
"worker process died". A log that passes ``--max-memory`` gets an out-of-memory row and the
worker goes on. Both are real: a ``sitecustomize`` on the workers' ``PYTHONPATH`` makes the
worker that reads ``poison.bag`` kill itself (up to a set number of times) or allocate memory
until it is stopped. The batch runs in a subprocess, so its fork server (or Dask cluster)
starts with that environment.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import etsid
from etsid.batch import VOLATILE, BatchSpec, read_results, run_batch
from etsid.batch.worker import WorkerDied
from etsid.ingest import ReadOptions

ROOT = Path(etsid.__file__).resolve().parents[1]

HOOK = """
import os
import signal

if os.environ.get("ETSID_TEST_POISON"):
    from etsid.batch import tasks

    _inspect = tasks.RUNNERS["inspect"]

    def inspect(path, *args, **kwargs):
        if "poison" in str(path):
            if os.environ["ETSID_TEST_POISON"] == "hog":
                hoard = [b"x" * 2**26 for _ in range(24)]  # 1.5 GB, 64 MB at a time
                del hoard
            else:
                deaths = os.environ["ETSID_TEST_DEATHS"]
                if len(os.listdir(deaths)) < int(os.environ["ETSID_TEST_MAX"]):
                    open(os.path.join(deaths, str(os.getpid())), "w").close()
                    os.kill(os.getpid(), signal.SIGKILL)
        return _inspect(path, *args, **kwargs)

    tasks.RUNNERS["inspect"] = inspect
"""

SCRIPT = """
import json, sys
from etsid.batch import BatchSpec, run_batch
from etsid.ingest import ReadOptions
if __name__ == "__main__":
    summary = run_batch(json.loads(sys.argv[1]), BatchSpec("inspect", read_options=ReadOptions()),
                        sys.argv[2], jobs=2, scheduler=sys.argv[3],
                        max_memory_mb=float(sys.argv[4]) if len(sys.argv) > 4 else None)
    print(summary.ok, summary.failed)
"""


@pytest.fixture
def logs(fleet: Path, tmp_path: Path) -> list[str]:
    """``poison.bag`` first (a good log: only the hook kills it), then three others."""
    root = tmp_path / "logs"
    root.mkdir()
    shutil.copy(fleet / "sub" / "b.bag", root / "poison.bag")
    shutil.copy(fleet / "a.tlog", root / "a.tlog")
    shutil.copytree(fleet / "sub" / "c", root / "c")
    shutil.copy(fleet / "d.mcap", root / "d.mcap")
    return [str(root / name) for name in ("poison.bag", "a.tlog", "c", "d.mcap")]


def _run_poisoned(logs: list[str], out: Path, scheduler: str, max_deaths: int = 0,
                  max_memory_mb: float | None = None,
                  extra_env: dict[str, str] | None = None) -> tuple[int, str]:
    """Run the batch with the hook armed: ``poison.bag`` kills its worker up to
    ``max_deaths`` times, or with ``max_memory_mb`` hogs memory. The number of worker deaths
    and the script's stdout (ok and failed counts)."""
    hook_dir = out.parent / f"{out.name}-hook"
    deaths = out.parent / f"{out.name}-deaths"
    hook_dir.mkdir()
    deaths.mkdir()
    (hook_dir / "sitecustomize.py").write_text(HOOK)
    script = hook_dir / "run.py"
    script.write_text(SCRIPT)
    env = {**os.environ, **(extra_env or {}),
           "PYTHONPATH": os.pathsep.join([str(hook_dir), str(ROOT)]),
           "ETSID_TEST_POISON": "hog" if max_memory_mb else "kill",
           "ETSID_TEST_DEATHS": str(deaths), "ETSID_TEST_MAX": str(max_deaths)}
    args = [json.dumps(logs), str(out), scheduler, *([str(max_memory_mb)] if max_memory_mb
                                                     else [])]
    done = subprocess.run([sys.executable, str(script), *args], env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return len(os.listdir(deaths)), done.stdout


def _rows(out: Path) -> dict[str, dict]:
    table = read_results(out).drop(columns=[*VOLATILE, "run_dir"])
    return {Path(row["input"]).name: row for row in table.to_dict("records")}


def _same(a: dict, b: dict) -> bool:
    return all(a[key] == b[key] or (a[key] != a[key] and b[key] != b[key]) for key in a)


def _assert_only_the_poison_failed(stdout: str, out: Path) -> None:
    assert stdout.split() == ["3", "1"]  # ok, failed
    rows = _rows(out)
    assert rows["poison.bag"]["error"] == str(WorkerDied())
    assert rows["poison.bag"]["error_kind"] == "WorkerDied"
    assert [rows[name]["status"] for name in ("a.tlog", "c", "d.mcap")] == ["ok"] * 3


def test_a_worker_killed_once_costs_no_row(logs: list[str], tmp_path: Path) -> None:
    clean = tmp_path / "clean"
    run_batch(logs, BatchSpec("inspect", read_options=ReadOptions()), clean, jobs=1)
    deaths, stdout = _run_poisoned(logs, tmp_path / "killed", "local", max_deaths=1)
    assert deaths == 1
    assert stdout.split() == ["4", "0"]
    expected, got = _rows(clean), _rows(tmp_path / "killed")
    assert set(got) == {"poison.bag", "a.tlog", "c", "d.mcap"}
    assert all(_same(expected[name], got[name]) for name in expected)


def test_a_log_that_kills_every_worker_is_the_only_error_row(logs: list[str],
                                                            tmp_path: Path) -> None:
    deaths, stdout = _run_poisoned(logs, tmp_path / "killed", "local", max_deaths=99)
    # two pools broken with it in flight, then one worker of its own
    assert deaths == 3
    _assert_only_the_poison_failed(stdout, tmp_path / "killed")


def test_dask_gives_the_same_row_after_its_retries(logs: list[str], tmp_path: Path) -> None:
    """Two logs per task: the task holding the poison dies on its try and the one retry
    allowed, is split into one task per log, and the poison's own task dies twice more;
    its partner and the other task lose nothing (they did when the batch arguments were
    scattered data, which died with the workers)."""
    pytest.importorskip("dask.distributed")
    env = {"DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "1",
           "DASK_DISTRIBUTED__SCHEDULER__WORKER_SATURATION": "1.0",
           "ETSID_BATCH_LOGS_PER_TASK": "2"}
    deaths, stdout = _run_poisoned(logs, tmp_path / "killed", "processes", max_deaths=99,
                                   extra_env=env)
    assert deaths == 4
    _assert_only_the_poison_failed(stdout, tmp_path / "killed")


def test_a_log_over_max_memory_is_an_error_row_and_its_worker_goes_on(
        logs: list[str], tmp_path: Path) -> None:
    """``--max-memory 600``: the workers idle at about 150 MB, the poison would take 1.5 GB
    more; it is stopped on the way with a MemoryError, and no worker dies."""
    deaths, stdout = _run_poisoned(logs, tmp_path / "hog", "local", max_memory_mb=600.0)
    assert deaths == 0
    assert stdout.split() == ["3", "1"]
    rows = _rows(tmp_path / "hog")
    assert rows["poison.bag"]["error"] == ("out of memory: the log needed more than "
                                           "--max-memory 600 MB")
    assert rows["poison.bag"]["error_kind"] == "MemoryError"
    assert len(rows["poison.bag"]["input_sha256"]) == 64  # the worker got as far as hashing
    peak = read_results(tmp_path / "hog").set_index("input")["peak_rss_mb"]
    assert 600.0 < peak[logs[0]] < 1200.0  # stopped past the limit, well before 1.5 GB more
    assert [rows[name]["status"] for name in ("a.tlog", "c", "d.mcap")] == ["ok"] * 3


def test_a_pool_that_breaks_between_two_submissions_loses_no_log(
        logs: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A worker can die after the runner's last wait and before its next submission: the
    pool then refuses the submission itself (``BrokenProcessPool`` from ``submit``). The log
    not submitted never ran, so it goes back in line for the next pool; every log still
    gets its own row (CI once saw this race end the whole batch with a traceback)."""
    from concurrent.futures.process import BrokenProcessPool

    from etsid.batch import local

    refused = []

    class RefusesOnce(local.ProcessPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):  # type: ignore[override]
            if len(refused) == 0 and getattr(self, "_submitted", 0) == 1:
                refused.append(args[0])
                raise BrokenProcessPool("a child process terminated abruptly")
            self._submitted = getattr(self, "_submitted", 0) + 1
            return super().submit(fn, *args, **kwargs)

    monkeypatch.setattr(local, "ProcessPoolExecutor", RefusesOnce)
    summary = run_batch(logs, BatchSpec("inspect", read_options=ReadOptions()),
                        tmp_path / "out", jobs=2, scheduler="local")
    assert refused, "the refusal was never exercised"
    assert (summary.ok, summary.failed) == (len(logs), 0)
