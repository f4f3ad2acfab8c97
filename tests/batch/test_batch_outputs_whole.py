"""Outputs written whole, and nothing left behind.

* ``etsid batch`` killed with SIGKILL takes its fork server, pool workers and resource
  tracker with it;
* runs written at once into one RUN_DIR (``etsid identify --out``) leave one whole run,
  never a mix;
* a full disk (a real tmpfs, mounted when the test runs as root) is a one-line error with
  no partial file left, in ``identify --out`` and in a batch.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd
import pytest

from etsid.errors import IdentError
from etsid.ident.rundir import RUN_FILES, Run, read_run, write_run

ETSID = [sys.executable, "-m", "etsid"]


def _children(pid: int) -> set[int]:
    """Every live descendant of ``pid`` (Linux /proc)."""
    found: set[int] = set()
    todo = [pid]
    while todo:
        parent = todo.pop()
        for task in Path(f"/proc/{parent}/task").glob("*"):
            try:
                kids = {int(k) for k in (task / "children").read_text().split()}
            except OSError:
                continue
            todo.extend(kids - found)
            found |= kids
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs Linux /proc")
def test_sigkill_of_the_batch_takes_its_workers_along(fleet: Path, tmp_path: Path) -> None:
    listing = tmp_path / "logs.txt"
    # enough work that the pool is busy when the batch is killed
    names = [str(fleet / n) for n in ("a.tlog", "d.mcap", "sub/b.bag", "sub/c")]
    for i in range(6):
        for name in names:
            copy = tmp_path / "logs" / f"{i}-{Path(name).name}"
            copy.parent.mkdir(exist_ok=True)
            if Path(name).is_dir():
                import shutil

                shutil.copytree(name, copy)
            else:
                copy.write_bytes(Path(name).read_bytes())
    listing.write_text("\n".join(str(p) for p in sorted((tmp_path / "logs").iterdir())))
    batch = subprocess.Popen([*ETSID, "batch", "identify", str(listing), "-o",
                              str(tmp_path / "out"), "-j", "2", "-q"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 600
        rows = tmp_path / "out" / "results" / "command=identify"
        # a first row written: the fork server, two workers and the resource tracker run
        while time.monotonic() < deadline and (
                not rows.is_dir() or not any(rows.glob("*.parquet"))):
            assert batch.poll() is None, batch.stderr.read().decode()[-2000:]
            time.sleep(0.1)
        family = _children(batch.pid)
        assert len(family) >= 4
        batch.send_signal(signal.SIGKILL)
        batch.wait(timeout=10)
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and any(_alive(p) for p in family):
            time.sleep(0.1)
        assert [p for p in family if _alive(p)] == []
    finally:
        if batch.poll() is None:
            batch.kill()


@pytest.fixture(scope="module")
def two_runs() -> tuple[Run, Run]:
    """Two different identifications of short synthetic flights (one with rules_final)."""
    from etsid.ident import IdentConfig, identify
    from etsid.ident.synthetic import rate_table

    first = identify(rate_table(600, seed=0), IdentConfig(ident_rate=0))
    second = identify(rate_table(700, seed=1), IdentConfig(ident_rate=0))
    second.rules_final = None
    return first, second


def test_runs_racing_into_one_out_leave_one_whole_run(two_runs: tuple[Run, Run],
                                                      tmp_path: Path) -> None:
    """Sixteen writes of two different runs at once into one RUN_DIR: afterwards it holds
    every file of exactly one of them (the earlier run's extra file gone), and the user's
    own file."""
    out = tmp_path / "run"
    out.mkdir()
    (out / "notes.txt").write_text("the user's own file")
    with ThreadPoolExecutor(8) as pool:
        list(pool.map(lambda i: write_run(two_runs[i % 2], out), range(16)))
        got = read_run(out)
        which = [r for r in two_runs if r.metrics == got.metrics]
        assert len(which) == 1
        assert len(got.predictions) == len(which[0].predictions)
        assert got.rules == which[0].rules
        assert (got.rules_final is None) == (which[0].rules_final is None)
        pool.submit(write_run, two_runs[1], out).result()
    got = read_run(out)
    assert got.metrics == two_runs[1].metrics and got.rules_final is None
    assert not (out / "rules_final.json").exists()
    assert (out / "notes.txt").read_text() == "the user's own file"
    assert not list(out.glob(".run-*"))


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A 512 KB tmpfs (needs root and a kernel that lets this process mount)."""
    mount = tmp_path / "disk"
    mount.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(mount)],
                          capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)


def _fill(disk: Path, leave_kb: int) -> None:
    stat = os.statvfs(disk)
    free = stat.f_bavail * stat.f_frsize
    (disk / "ballast").write_bytes(b"\0" * max(0, free - leave_kb * 1024))


def test_a_full_disk_is_one_line_and_leaves_the_earlier_run_whole(
        two_runs: tuple[Run, Run], small_disk: Path) -> None:
    out = small_disk / "run"
    write_run(two_runs[0], out)
    before = {name: (out / name).read_bytes() for name in RUN_FILES if (out / name).exists()}
    _fill(small_disk, leave_kb=8)
    with pytest.raises(IdentError) as caught:
        write_run(two_runs[1], out)
    assert str(caught.value) == (f"{out}: cannot write the run directory (No space left "
                                 "on device)")
    after = {name: (out / name).read_bytes() for name in RUN_FILES if (out / name).exists()}
    assert after == before
    assert not list(out.glob(".run-*"))


def test_a_batch_on_a_full_disk_stops_in_one_line_with_no_partial_file(
        fleet: Path, small_disk: Path) -> None:
    out = small_disk / "fleet"
    logs = [str(fleet / n) for n in ("a.tlog", "d.mcap", "sub/b.bag", "sub/c")]
    done = subprocess.run([*ETSID, "batch", "ingest", *logs, "-o", str(out), "-j", "1",
                           "-q"], capture_output=True, text=True, timeout=300)
    assert "Traceback" not in done.stderr and "internal error" not in done.stderr
    if done.returncode == 0:  # rows fit, the tables did not: every log says why
        rows = pd.concat(pd.read_parquet(p) for p in out.rglob("results/*/*.parquet"))
        assert (rows["error"] == "cannot write the run directory (No space left on "
                                 "device)").sum() >= 1
    else:
        assert done.stderr.strip().startswith("etsid: error: ")
        assert "No space left on device" in done.stderr
    leftovers = [p for p in out.rglob("*") if p.name.startswith(".")]
    assert leftovers == []
    for table in out.rglob("*.parquet"):  # whatever is there is whole
        pd.read_parquet(table)
