"""Format detection and the CLI's one-line errors for inputs no reader should see."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from etsid import __version__
from etsid.cli import cli
from etsid.errors import IngestError
from etsid.ingest.detect import detect_format

_NOISE = np.random.default_rng(20).bytes(5 * 64)  # fixed: the same test ids in every process


def _noise(i: int, n: int = 64) -> bytes:
    """Random bytes, the same in every run (pytest-xdist workers collect the same ids)."""
    return _NOISE[64 * i: 64 * i + n]


def run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(cli, list(args))
    return result.exit_code, result.output


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("empty.tlog", b"", "empty file"),
        ("random.bag", _noise(0), "not a ROS 1 bag"),
        ("random.ulg", _noise(1), "not a PX4 ULog file"),
        ("random.mcap", _noise(2), "not an MCAP file"),
        ("random.db3", _noise(3), "not a ROS 2 bag database"),
        ("random.bin", b"\x00\x01" + _noise(4, 62), "not an ArduPilot DataFlash log"),
        ("random.tlog", b"\x00" * 8 + b"\x42" * 40, "not a MAVLink telemetry log"),
        ("notes.txt", b"hello", "unknown log format"),
    ],
    ids=["empty.tlog", "random.bag", "random.ulg", "random.mcap", "random.db3", "random.bin",
         "random.tlog", "notes.txt"],
)
def test_bad_files_one_line_errors(tmp_path: Path, name: str, content: bytes,
                                   message: str) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(IngestError, match=message):
        detect_format(path)
    for command in ("inspect", "ingest"):
        extra = ["-o", str(tmp_path / "out.parquet")] if command == "ingest" else []
        code, output = run(command, str(path), *extra)
        assert code == 1
        assert "Traceback" not in output
        lines = output.strip().splitlines()
        assert len(lines) == 1 and name in lines[0] and message in lines[0]


def test_directory_without_metadata(tmp_path: Path) -> None:
    (tmp_path / "bag").mkdir()
    (tmp_path / "bag" / "bag_0.db3").write_bytes(b"SQLite format 3\x00")
    with pytest.raises(IngestError, match="without metadata.yaml.*bag_0.db3"):
        detect_format(tmp_path / "bag")


def test_missing_and_unreadable_paths(tmp_path: Path) -> None:
    code, output = run("inspect", str(tmp_path / "nope.tlog"))
    assert code == 1 and "no such file" in output
    dangling = tmp_path / "gone.tlog"
    dangling.symlink_to(tmp_path / "deleted.tlog")
    code, output = run("inspect", str(dangling))
    assert code == 1 and "gone.tlog" in output and "no such file" in output


def test_version_and_help() -> None:
    code, output = run("--version")
    assert code == 0 and __version__ in output
    code, output = run("--help")
    assert code == 0
    import click

    ctx = click.Context(cli)
    names = cli.list_commands(ctx)
    assert {"inspect", "ingest", "simulate", "identify", "report"} <= set(names)
    for name in names:
        command = cli.get_command(ctx, name)
        assert command is not None and command.help, f"command {name} has no help text"
        assert name in output


def test_bad_option_is_usage_error(tmp_path: Path) -> None:
    code, output = run("ingest", str(tmp_path / "x.tlog"), "-o", str(tmp_path / "x.txt"))
    assert code == 2 and "parquet" in output


def test_inspect_says_when_nothing_maps() -> None:
    """inspect lists a log without flight data (exit 0) and says ingest has nothing to take."""
    talker = Path(__file__).parents[1] / "data" / "ros" / "ros2_talker_db3"
    code, output = run("inspect", str(talker))
    assert code == 0 and "std_msgs/msg/String" in output and "nothing to ingest" in output
    code, output = run("ingest", str(talker), "-o", "unused.parquet")
    assert code == 1 and "no usable flight data" in output
