"""A real Dask cluster started from the command line: ``dask scheduler`` and two
``dask worker`` processes on localhost TCP, ``etsid batch … --scheduler tcp://…``, one worker
killed (SIGKILL) mid-run. Every log has exactly one row, and the rows equal the local run's."""

from __future__ import annotations

import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

from etsid.batch import VOLATILE, BatchSpec, read_results, run_batch
from etsid.ingest import ReadOptions

pytest.importorskip("dask.distributed")

COPIES = 6
"""Copies of each of the four fleet logs: 24 logs, enough to kill a worker mid-run."""


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _dask(*args: str, log: Path) -> subprocess.Popen[bytes]:
    handle = log.open("wb")
    return subprocess.Popen([str(Path(sys.executable).with_name("dask")), *args],
                            stdout=handle, stderr=subprocess.STDOUT)


@pytest.fixture
def cluster(tmp_path: Path) -> Iterator[tuple[str, list[subprocess.Popen[bytes]]]]:
    """The scheduler address and the two worker processes (no nanny: a killed worker
    stays dead)."""
    from dask.distributed import Client

    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    logs = tmp_path / "dask-logs"
    logs.mkdir()
    procs = [_dask("scheduler", "--host", "127.0.0.1", "--port", str(port),
                   "--no-dashboard", log=logs / "scheduler.txt")]
    try:
        procs += [_dask("worker", address, "--nthreads", "1", "--no-nanny",
                        "--no-dashboard", "--host", "127.0.0.1", "--name", f"w{i}",
                        log=logs / f"worker{i}.txt") for i in range(2)]
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
        yield address, procs[1:]
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
            proc.wait(timeout=30)


def test_cli_cluster_with_a_killed_worker_gives_one_row_per_log_as_the_local_run(
        fleet: Path, tmp_path: Path, cluster: tuple[str, list[subprocess.Popen[bytes]]]
) -> None:
    address, workers = cluster
    sources = {"a.tlog": fleet / "a.tlog", "d.mcap": fleet / "d.mcap",
               "b.bag": fleet / "sub" / "b.bag", "c": fleet / "sub" / "c"}
    logs = tmp_path / "logs"
    logs.mkdir()
    source_of: dict[str, str] = {}
    for i in range(COPIES):
        for name, source in sources.items():
            copy = logs / f"{i}-{name}"
            if source.is_dir():
                shutil.copytree(source, copy)
            else:
                shutil.copy(source, copy)
            source_of[str(copy)] = str(source)
    out = tmp_path / "out"
    batch = subprocess.Popen([str(Path(sys.executable).with_name("etsid")), "batch", "ingest",
                              str(logs), "-o", str(out), "--scheduler", address, "-q"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    rows = out / "results" / "command=ingest"
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline and batch.poll() is None and (
            not rows.is_dir() or len(list(rows.glob("*.parquet"))) < 4):
        time.sleep(0.05)
    written_at_kill = len(list(rows.glob("*.parquet"))) if rows.is_dir() else 0
    workers[0].send_signal(signal.SIGKILL)
    stdout, stderr = batch.communicate(timeout=300)
    assert batch.returncode == 0, stderr.decode()[-3000:]
    total = len(source_of)
    assert 4 <= written_at_kill < total  # killed mid-run
    assert f"{total} logs: {total} ok, 0 failed" in stdout.decode()
    # every log exactly one row file, one row
    files = sorted(rows.glob("*.parquet"))
    raw = pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)
    assert len(files) == total and sorted(raw["input"]) == sorted(source_of)
    # the rows are the local run's, log for log (the copies hold the same bytes)
    local = tmp_path / "local"
    run_batch(sorted(set(source_of.values())), BatchSpec("ingest", read_options=ReadOptions()),
              local, jobs=1)
    drop = [*VOLATILE, "input", "run_dir"]
    expected = read_results(local).set_index("input")
    got = read_results(out)
    assert {w.split(":")[0] for w in got["worker"]} == {socket.gethostname()}
    # the rows come from the two command-line workers (which of them ran how many is the
    # scheduler's choice: on an idle machine the first rows may all be the survivor's)
    assert 1 <= got["worker"].nunique() <= 2
    for _, row in got.iterrows():
        want = expected.loc[source_of[row["input"]]]
        mine = row.drop(labels=drop)
        want = want.drop(labels=[c for c in drop if c != "input"])
        assert mine.equals(want[mine.index]), row["input"]


def test_host_preload_forks_the_dask_workers_of_a_host_from_one_warm_server(
        fleet: Path, tmp_path: Path) -> None:
    """``dask worker --nworkers 2 --preload-nanny etsid.batch.dask_host``: both worker
    processes are children of one fork server (not of the nanny), warm and with the
    server's objects frozen before their first task, and they run a batch whose rows are
    the local run's; etsid's worker plugin stops the profiler and slows the event loop's
    callbacks while it is installed, and restores them when it is removed."""
    from dask.distributed import Client

    def worker_facts() -> tuple[int, bool, int]:  # local: sent to the workers by value
        """(parent pid, warm for identify, objects frozen) of the worker it runs in."""
        import gc
        import os

        from etsid.batch import tasks

        return os.getppid(), "identify" in tasks.WARMED, gc.get_freeze_count()

    def callbacks(dask_worker: Any) -> dict[str, tuple[float, bool]]:
        """The worker's periodic callbacks: name → (interval ms, running)."""
        return {name: (callback.callback_time, callback.is_running())
                for name, callback in dask_worker.periodic_callbacks.items()}

    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = [_dask("scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard",
                   log=tmp_path / "scheduler.txt")]
    try:
        procs.append(_dask("worker", address, "--nworkers", "2", "--nthreads", "1",
                           "--preload-nanny", "etsid.batch.dask_host", "--no-dashboard",
                           "--host", "127.0.0.1", log=tmp_path / "worker.txt"))
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
            facts = list(client.run(worker_facts).values())
        parents = {parent for parent, _, _ in facts}
        assert len(facts) == 2 and len(parents) == 1, facts
        assert parents != {procs[1].pid}  # not started by the nanny itself
        assert all(warm and frozen > 0 for _, warm, frozen in facts), facts
        logs = [str(fleet / "a.tlog"), str(fleet / "d.mcap"), str(fleet / "broken.tlog")]
        spec = BatchSpec("ingest", read_options=ReadOptions())
        run_batch(logs, spec, tmp_path / "dask", jobs=2, scheduler=address)
        with Client(address, timeout="60s") as client:
            # while etsid's plugin is installed: no profiler, a quieter event loop
            during = list(client.run(callbacks).values())
            client.unregister_worker_plugin("etsid-warm")
            after = list(client.run(callbacks).values())
        assert all(c["tick"] == (1000.0, True) and c["memory_monitor"] == (1000.0, True)
                   and not c["profile"][1] for c in during), during
        assert all(c["tick"] == (20.0, True) and c["memory_monitor"] == (100.0, True)
                   and c["profile"][1] for c in after), after
    finally:
        for proc in reversed(procs):
            proc.terminate()
            proc.wait(timeout=60)
    run_batch(logs, spec, tmp_path / "local", jobs=1)
    drop = list(VOLATILE)
    got = read_results(tmp_path / "dask").drop(columns=drop)
    assert got.equals(read_results(tmp_path / "local").drop(columns=drop))
    assert got["status"].tolist().count("error") == 1
