"""Discovery of a batch's inputs: directories, ROS 2 bag directories, list files, pairs."""

from __future__ import annotations

from pathlib import Path

import pytest

from etsid.batch import BatchError, find_inputs, read_pairs
from etsid.batch.inputs import is_url, run_name


def test_directory_search_finds_every_format_and_the_bag_directory(fleet: Path) -> None:
    found = find_inputs([fleet])
    rel = sorted(str(Path(f).relative_to(fleet)) for f in found)
    assert rel == ["a.tlog", "broken.tlog", "d.mcap", "sub/b.bag", "sub/c"]
    bag = fleet / "sub" / "c"
    assert (bag / "metadata.yaml").is_file()
    # the bag's own storage file is not an input of its own
    assert not any(f.endswith(".db3") for f in found)


def test_bag_directory_named_directly_is_one_input(fleet: Path) -> None:
    assert find_inputs([fleet / "sub" / "c"]) == [str(fleet / "sub" / "c")]


def test_list_file_relative_paths_duplicates_and_missing(fleet: Path, tmp_path: Path) -> None:
    listing = tmp_path / "logs.txt"
    listing.write_text(f"# fleet\n{fleet / 'a.tlog'}\n\n{fleet / 'a.tlog'}  # again\n"
                       "missing.ulg\n")
    found = find_inputs([listing, fleet / "d.mcap"])
    assert found == [str(fleet / "a.tlog"), str(tmp_path / "missing.ulg"),
                     str(fleet / "d.mcap")]


def test_out_directory_is_not_searched(fleet: Path, tmp_path: Path) -> None:
    root = tmp_path / "logs"
    out = root / "batch"
    (out / "runs").mkdir(parents=True)
    (root / "x.tlog").write_bytes((fleet / "a.tlog").read_bytes())
    (out / "runs" / "copy.tlog").write_bytes(b"x")
    assert find_inputs([root], exclude=out) == [str(root / "x.tlog")]


def test_saved_tables_in_a_directory_are_not_run_and_are_said(fleet: Path,
                                                              tmp_path: Path) -> None:
    """A folder of results is full of Parquet files that are not flights, so tables are
    taken only when named; the ones a directory holds are counted, never dropped silently."""
    from click.testing import CliRunner

    from etsid.cli import cli

    root = tmp_path / "logs"
    (root / "tables").mkdir(parents=True)
    (root / "x.tlog").write_bytes((fleet / "a.tlog").read_bytes())
    (root / "tables" / "t1.parquet").write_bytes(b"PAR1")
    (root / "tables" / "t2.csv").write_text("t,p\n")
    tables: list[str] = []
    assert find_inputs([root], unsearched=tables) == [str(root / "x.tlog")]
    assert tables == [str(root / "tables" / "t1.parquet"), str(root / "tables" / "t2.csv")]
    named = root / "tables" / "t1.parquet"
    assert find_inputs([named]) == [str(named)]

    runner = CliRunner()
    only = runner.invoke(cli, ["batch", "inspect", str(root / "tables"),
                               "-o", str(tmp_path / "b1"), "-j", "1", "-q"])
    assert only.exit_code != 0
    error = only.output.strip().splitlines()
    assert len(error) == 1 and "Traceback" not in only.output
    assert error[0] == (f"etsid: error: no logs to run: the directories hold 2 saved tables "
                        f"(.csv, .parquet) and no log; saved tables run only when named, "
                        f"e.g. {root / 'tables'}/*.parquet")
    both = runner.invoke(cli, ["batch", "inspect", str(root), "-o", str(tmp_path / "b2"),
                               "-j", "1", "-q"])
    assert both.exit_code == 0, both.output
    assert "note: 2 saved tables (.csv, .parquet) in the directories not run" in both.output
    assert "1 log: 1 ok, 0 failed" in both.output


def test_pairs_csv(tmp_path: Path) -> None:
    csv = tmp_path / "pairs.csv"
    csv.write_text("sim,real\nsim/a.tlog, real/a.ulg\n\n/abs/b.bag,s3://bucket/b.ulg\n")
    assert read_pairs([csv]) == [(str(tmp_path / "sim/a.tlog"), str(tmp_path / "real/a.ulg")),
                                 ("/abs/b.bag", "s3://bucket/b.ulg")]
    csv.write_text("a.tlog,b.tlog,c.tlog\n")
    with pytest.raises(BatchError, match=r"pairs.csv: line 1: expected SIM,REAL"):
        read_pairs([csv])


def test_urls_and_run_names() -> None:
    assert is_url("s3://bucket/log.ulg") and is_url("file:///tmp/x.tlog")
    assert not is_url("/tmp/x.tlog") and not is_url("C://x")
    assert run_name("s3://bucket/flight 1.ulg") == "flight_1-ulg"
    assert {run_name(f"/d/f.{x}") for x in ("bag", "mcap", "tlog")} == {"f-bag", "f-mcap",
                                                                        "f-tlog"}
    assert run_name("/data/bag_dir/") == "bag_dir"
