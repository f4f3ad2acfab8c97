"""Exit codes a script can trust: a batch that ran nothing or whose every log failed is
not a success, and an error before any log ran leaves no batch directory behind."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner

from etsid.batch import EXIT_ALL_FAILED, read_results
from etsid.cli import cli


def test_a_missing_input_runs_nothing_and_creates_nothing(fleet: Path, tmp_path: Path) -> None:
    out = tmp_path / "deep" / "b1"
    result = CliRunner().invoke(cli, ["batch", "identify", str(tmp_path / "no_such_dir"),
                                      str(fleet / "a.tlog"), "--out", str(out), "-q"])
    assert result.exit_code == 1
    assert result.output.strip() == (f"etsid: error: {tmp_path / 'no_such_dir'}: no such "
                                     "file or directory (nothing run)")
    assert not (tmp_path / "deep").exists()


def test_every_log_failed_is_exit_code_3_with_the_rows_kept(fleet: Path,
                                                            tmp_path: Path) -> None:
    out = tmp_path / "b2"
    result = CliRunner().invoke(cli, ["batch", "inspect", str(fleet / "broken.tlog"),
                                      "--out", str(out), "-j", "1", "-q"])
    assert EXIT_ALL_FAILED == 3
    assert result.exit_code == EXIT_ALL_FAILED, result.output
    assert "1 log: 0 ok, 1 failed" in result.output
    assert result.output.rstrip().endswith("every log failed (exit code 3)")
    rows = read_results(out)
    assert list(rows["status"]) == ["error"]


def test_some_failed_is_exit_code_0(fleet: Path, tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["batch", "inspect", str(fleet / "broken.tlog"),
                                      str(fleet / "a.tlog"), "--out", str(tmp_path / "b3"),
                                      "-j", "1", "-q"])
    assert result.exit_code == 0, result.output
    assert "2 logs: 1 ok, 1 failed" in result.output


def test_a_bad_scheduler_leaves_no_empty_folder(fleet: Path, tmp_path: Path) -> None:
    out = tmp_path / "b4"
    result = CliRunner().invoke(cli, ["batch", "inspect", str(fleet / "a.tlog"), "--out",
                                      str(out), "--scheduler", "bogus", "-q"])
    assert result.exit_code == 1
    assert "--scheduler 'bogus'" in result.output
    assert not out.exists()
