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
    assert run_name("s3://bucket/flight 1.ulg") == "flight_1"
    assert run_name("/data/bag_dir/") == "bag_dir"
