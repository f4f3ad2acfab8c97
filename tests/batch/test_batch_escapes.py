"""A batch's inputs and results cannot make it read or write where it was not asked to.

URLs are opened only for allowed schemes (``file`` and ``--protocol``), their paths are
normalised, copies land only in a private temporary folder that is removed afterwards, and
a results dataset's ``run_dir`` cannot send the fleet report outside the batch directory.
"""

from __future__ import annotations

import json
import shutil
import socket
import tempfile
from pathlib import Path

import pytest
from click.testing import CliRunner

from etsid.batch import BatchSpec, find_inputs, read_results, run_batch
from etsid.batch.fetch import check_url, normalise_url
from etsid.batch.results import write_row
from etsid.cli import cli
from etsid.errors import BatchError
from etsid.ingest import ReadOptions


@pytest.fixture
def private_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The system temporary folder, here empty and watched."""
    tmp = tmp_path / "systmp"
    tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    return tmp


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def test_urls_are_normalised_and_checked_against_the_allow_list() -> None:
    assert normalise_url("file:///data/sub/..") == "file:///data"
    assert normalise_url("s3://bucket/a/./b/../c.ulg") == "s3://bucket/a/c.ulg"
    assert normalise_url("file:///data/bag/") == "file:///data/bag/"
    assert check_url("FILE:///x/../y.tlog") == "file:///y.tlog"
    with pytest.raises(BatchError, match=r"^ftp://h/x.tlog: URL scheme 'ftp' is not allowed "
                                         r"\(allowed: file; name it with --protocol ftp"):
        check_url("ftp://h/x.tlog")
    assert check_url("s3://b/x.ulg", ("file", "s3")) == "s3://b/x.ulg"


def test_a_dotdot_url_copies_nothing_and_is_an_error_row(fleet: Path, tmp_path: Path,
                                                          private_tmp: Path) -> None:
    """``file:///…/sub/..`` used to copy the parent tree into the temporary folder's parent;
    now it is the directory it names, which is not a log."""
    root = tmp_path / "data"
    shutil.copytree(fleet, root)
    before = _tree(root)
    pairs = tmp_path / "pairs.csv"
    pairs.write_text(f"{root.as_uri()}/sub/..,{(root / 'a.tlog').as_uri()}\n")
    listing = tmp_path / "logs.txt"
    listing.write_text(f"{root.as_uri()}/sub/..\n{root.as_uri()}/sub/../a.tlog\n")
    out = tmp_path / "out"
    runner = CliRunner()
    result = runner.invoke(cli, ["batch", "inspect", str(listing), "-o", str(out), "-j", "1",
                                 "-q"])
    assert result.exit_code == 0, result.output
    rows = read_results(out).set_index("input")
    # the directory URL was searched as a directory (what a named directory means)...
    assert f"file://{root}/a.tlog" in rows.index
    # ...and as a pair member it is refused in one line
    gap = runner.invoke(cli, ["batch", "gap", str(pairs), "-o", str(tmp_path / "g"), "-j", "1",
                              "-q"])
    assert gap.exit_code == 3, gap.output  # its only pair failed
    row = read_results(tmp_path / "g").iloc[0]
    assert row["status"] == "error"
    assert row["error"] == (f"{root.as_uri()}/sub/..: a directory, not a log (only a ROS 2 "
                            "bag directory, with metadata.yaml, is one log; name a directory "
                            "as an input to search it)")
    assert _tree(root) == before
    assert list(private_tmp.iterdir()) == []
    assert not (tmp_path / "a.tlog").exists() and not (tmp_path / "sub").exists()


def test_schemes_not_allowed_are_error_rows_without_a_connection(fleet: Path,
                                                                 tmp_path: Path) -> None:
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    server.setblocking(False)
    port = server.getsockname()[1]
    listing = tmp_path / "logs.txt"
    ftp, hdfs = f"ftp://127.0.0.1:{port}/x.tlog", f"hdfs://127.0.0.1:{port}/logs/"
    listing.write_text(f"{ftp}\n{hdfs}\n{fleet / 'a.tlog'}\n")
    out = tmp_path / "out"
    result = CliRunner().invoke(cli, ["batch", "inspect", str(listing), "-o", str(out),
                                      "-j", "1", "-q"])
    assert result.exit_code == 0, result.output
    assert "internal error" not in result.output
    rows = read_results(out).set_index("input")
    assert rows.loc[str(fleet / "a.tlog"), "status"] == "ok"
    assert rows.loc[ftp, "error"].startswith(f"{ftp}: URL scheme 'ftp' is not allowed")
    assert rows.loc[hdfs, "error"].startswith(f"{hdfs}: URL scheme 'hdfs' is not allowed")
    with pytest.raises(BlockingIOError):  # nobody knocked
        server.accept()
    server.close()


def test_a_named_protocol_is_fetched_into_a_private_folder_and_removed(
        fleet: Path, tmp_path: Path, private_tmp: Path) -> None:
    """``--protocol memory`` (fsspec's in-memory file system, so the test needs no network):
    the log is copied under a name made here, read, and the copy removed."""
    fsspec = pytest.importorskip("fsspec")
    fs = fsspec.filesystem("memory")
    fs.pipe("/fleet/x/a.tlog", (fleet / "a.tlog").read_bytes())
    fs.pipe("/fleet/x/notes.bin", b"not a log")
    fs.mkdir("/fleet/dir")
    fs.pipe("/fleet/dir/readme", b"x")
    urls = ["memory://fleet/x/../x/a.tlog", "memory://fleet/dir/", "memory://fleet/x/a.tlog"]
    assert find_inputs(urls[:1]) == urls[:1]  # not allowed: kept as given, not opened
    # allowed: the file URL normalised (once), the directory URL searched (no log in it)
    assert find_inputs(urls, protocols=("file", "memory")) == ["memory://fleet/x/a.tlog"]
    spec = BatchSpec("inspect", read_options=ReadOptions(), protocols=("file", "memory"))
    out = tmp_path / "out"
    run_batch(["memory://fleet/x/../x/a.tlog", "memory://fleet/dir/"], spec, out, jobs=1)
    rows = read_results(out).set_index("input")
    assert rows.loc["memory://fleet/x/../x/a.tlog", "status"] == "ok"
    assert rows.loc["memory://fleet/dir/", "error"].startswith(
        "memory://fleet/dir/: a directory, not a log")
    assert list(private_tmp.iterdir()) == []


def test_a_crafted_run_dir_cannot_send_the_report_outside(fleet: Path, tmp_path: Path) -> None:
    """Rows whose ``run_dir`` points at a real run folder outside the batch (``../victim``,
    absolute, through ``runs/..``): the report used to write ``victim/report/``."""
    from etsid.ident import IdentConfig, identify, write_run
    from etsid.ident.synthetic import rate_table

    batch = tmp_path / "fleet"
    run_batch([str(fleet / "a.tlog")], BatchSpec("inspect", read_options=ReadOptions()),
              batch, jobs=1)
    meta = json.loads((batch / "batch.json").read_text())
    meta["command"] = "identify"  # so that the report ranks the rows and links their runs
    (batch / "batch.json").write_text(json.dumps(meta))
    victim = tmp_path / "victim"
    write_run(identify(rate_table(600, seed=0), IdentConfig(ident_rate=0)), victim)
    before = _tree(victim)
    for i, crafted in enumerate(["../victim", str(victim), "runs/../../victim"]):
        forged = {"input": f"forged{i}.tlog", "options_digest": meta["options_digest"],
                  "run_dir": crafted, "status": "ok", "fit_one_step": 90.0 + i,
                  "finished": f"z{i}"}
        write_row(batch, "identify", forged, f"{i:032d}")
    result = CliRunner().invoke(cli, ["report", str(batch)])
    assert result.exit_code == 0, result.output
    assert _tree(victim) == before
    page = (batch / "report" / "index.html").read_text()
    assert "forged0.tlog" in page and "victim" not in page
    assert not list(batch.glob(".report-*"))


def test_an_interrupted_fleet_report_leaves_the_previous_one_whole(
        fleet: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from etsid.report import fleet as fleet_report

    batch = tmp_path / "fleet"
    run_batch([str(fleet / "a.tlog")], BatchSpec("inspect", read_options=ReadOptions()),
              batch, jobs=1)
    fleet_report.make_fleet_report(batch)
    before = {p.name: p.read_bytes() for p in (batch / "report").iterdir()}

    def interrupted(*args: object, **kwargs: object) -> str:
        raise KeyboardInterrupt

    monkeypatch.setattr(fleet_report._Parts, "markdown", interrupted)
    with pytest.raises(KeyboardInterrupt):
        fleet_report.make_fleet_report(batch)
    assert {p.name: p.read_bytes() for p in (batch / "report").iterdir()} == before
    assert not list(batch.glob(".report-*"))
    shutil.rmtree(batch / "report")
    with pytest.raises(KeyboardInterrupt):
        fleet_report.make_fleet_report(batch)
    assert not (batch / "report").exists() and not list(batch.glob(".report-*"))
