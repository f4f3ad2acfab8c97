"""Hostile files beside the logs (tests/fuzz/files.py): the cheap cases, each in a child
process bounded like the structure cases, give one clean error line or a result whose
files pass their check. ``python benchmarks/fuzz.py --files`` runs every case."""

from __future__ import annotations

from pathlib import Path

import files
import pytest
import structure

CHEAP = [c.name for c in files.CASES if c.cheap]


@pytest.mark.parametrize("name", CHEAP)
def test_hostile_file_is_bounded_and_answered(name: str, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(files, "CACHE", tmp_path.parent / "etsid-files-cache")
    case = files.case(name)
    verdict = structure.run_case(case, tmp_path / name)
    assert verdict.ok, (f"{name} ({case.what}): {verdict.detail} after {verdict.seconds:.1f} s, "
                        f"{verdict.peak_mb:.0f} MB\n" + "\n".join(verdict.lines[-5:]))


def test_the_report_check_fails_a_template_holding_the_files_string(tmp_path: Path) -> None:
    # the check is not "it ran": a unit inside a tooltip template, raw in the page, fails
    page = tmp_path / "run" / "report"
    page.mkdir(parents=True)
    (page / "report.md").write_text("ok\n")
    (page / "index.html").write_text(
        '<script>{"tooltips":[["co2","@{y}{0.0} ' + files.SCRIPT + '"]]}</script>')
    assert "tooltip template" in files._report_clean(tmp_path / "run")
    (page / "index.html").write_text(f"<p>{files.RLO}</p>")
    assert "raw" in files._report_clean(tmp_path / "run")


def test_rosbags_mcap_chunks_decompress_within_the_declared_size() -> None:
    import lz4.frame
    from rosbags.rosbag2 import storage_mcap
    from rosbags.rosbag2.errors import ReaderError

    from etsid.ingest.ros import bounded

    bounded.install()
    lz4_entry = storage_mcap.DECOMPRESSORS["lz4"]
    data = bytes(range(256)) * 64
    assert lz4_entry(lz4.frame.compress(data), len(data)) == data  # an honest chunk: as is
    bomb = structure._lz4_zeros(64 << 20)  # 64 MiB of zeros, the header says 1000 bytes
    with pytest.raises(ReaderError, match="more than the declared 1000 bytes"):
        lz4_entry(bomb, 1000)
    with pytest.raises(ReaderError, match="above the limit"):
        storage_mcap.DECOMPRESSORS["zstd"](b"", 1 << 40)


def test_a_bag_with_a_lying_chunk_keeps_the_rest_exactly(tmp_path: Path) -> None:
    """The first chunk (which holds the Schema/Channel records) replaced by a 64 MiB lz4
    bomb: the rest of the bag is read (channels from the summary section), equal to the
    intact bag's table on the same rows, and the skip is said."""
    import numpy as np

    from etsid.ingest import read_log

    (tmp_path / "bomb").mkdir()
    (tmp_path / "intact").mkdir()
    bomb = read_log(files._bag_dir_lying_chunk(nbytes=64 << 20)(tmp_path / "bomb"))
    intact = read_log(files._bag_dir_lying_chunk(nbytes=0)(tmp_path / "intact"))
    notes = " ".join(bomb.attrs["warnings"])
    assert "skipped 1 damaged stretch" in notes and "more than the declared" in notes
    assert not any("skipped" in w for w in intact.attrs["warnings"])
    assert 2800 <= len(bomb) < len(intact)
    for col in ("p", "q", "r", "roll", "alt"):  # signals on the IMU grid and the range
        np.testing.assert_allclose(bomb[col].to_numpy(), intact[col].to_numpy()[-len(bomb):],
                                   rtol=0, atol=1e-9, err_msg=col)
