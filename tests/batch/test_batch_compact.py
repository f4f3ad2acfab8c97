"""A large results partition is compacted into part files without losing or doubling a row,
and a log run again after compaction (``--resume`` retries failures) reads as one row."""

from __future__ import annotations

import hashlib
from pathlib import Path

from etsid.batch import read_results
from etsid.batch.results import compact, done_keys, partition_dir, write_row

DIGEST = "d" * 64


def _sha(i: int) -> str:
    return hashlib.sha256(str(i).encode()).hexdigest()


def _row(i: int, status: str, finished: str) -> dict:
    return {"input": f"/logs/flight{i:03d}.tlog", "input_sha256": _sha(i),
            "options_digest": DIGEST, "status": status, "rows": i * 10,
            "error": None if status == "ok" else "bad log", "finished": finished,
            "duration_s": i / 3}


def test_compaction_keeps_every_row_once_and_resume_reads_it(tmp_path: Path) -> None:
    for i in range(40):
        write_row(tmp_path, "inspect", _row(i, "ok" if i % 4 else "error", "2026-01-01T00"),
                  _sha(i))
    before = read_results(tmp_path)
    keys = done_keys(tmp_path, "inspect", DIGEST)
    assert compact(tmp_path, "inspect", min_files=100) == 0  # too few to bother
    assert compact(tmp_path, "inspect", min_files=10) == 40
    files = list(partition_dir(tmp_path, "inspect").iterdir())
    assert [f.name[:5] for f in files] == ["part-"]
    after = read_results(tmp_path)
    assert after.equals(before)
    assert after["rows"].dtype == before["rows"].dtype == "int64"
    assert done_keys(tmp_path, "inspect", DIGEST) == keys and len(keys) == 30
    assert len(done_keys(tmp_path, "inspect", DIGEST, retry_failed=False)) == 40
    # a failed log run again: its new row file sits beside the old row in the part file
    write_row(tmp_path, "inspect", _row(4, "ok", "2026-01-02T00"), _sha(4))
    rows = read_results(tmp_path)
    assert len(rows) == 40
    assert rows.set_index("input").loc["/logs/flight004.tlog", "status"] == "ok"
    assert _sha(4)[:32] in done_keys(tmp_path, "inspect", DIGEST)
    # compacting again folds it in: still one row per log
    assert compact(tmp_path, "inspect", min_files=2) == 2
    assert len(list(partition_dir(tmp_path, "inspect").iterdir())) == 1
    assert read_results(tmp_path).equals(rows)
