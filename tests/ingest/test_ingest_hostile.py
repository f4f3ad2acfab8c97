"""Hostile structure in the parsing layer: bounded decompression, the DataFlash indexer
that resynchronises, ULog message chains and recursive formats, one bad ROS message.

The whole-file cases (built with the real writers, run in bounded child processes) are in
tests/fuzz/test_structure.py; these check the pieces in-process against known answers.
"""

from __future__ import annotations

import bz2
import mmap
import random
import sqlite3
import struct
from pathlib import Path

import lz4.frame
import pytest
import zstandard

from etsid.ingest import dataflash_index, read_log, ulog_clean
from etsid.ingest.base import printable
from etsid.ingest.inflate import MAX_CHUNK_BYTES, inflate

ROOT = Path(__file__).resolve().parents[2]
BIN = ROOT / "tests" / "data" / "arduplane_truncated.BIN"
ULG = ROOT / "tests" / "data" / "px4_cubeorange_real.ulg"
GIB = 1 << 30


def _zeros_frame(kind: str, nbytes: int) -> bytes:
    block = bytes(1 << 24)
    if kind == "zstd":
        obj = zstandard.ZstdCompressor(level=1).compressobj(size=nbytes)
        return b"".join(obj.compress(block) for _ in range(nbytes // len(block))) + obj.flush()
    if kind == "lz4":
        comp = lz4.frame.LZ4FrameCompressor()
        return (comp.begin() + b"".join(comp.compress(block)
                                        for _ in range(nbytes // len(block))) + comp.flush())
    comp = bz2.BZ2Compressor(1)
    return b"".join(comp.compress(block) for _ in range(nbytes // len(block))) + comp.flush()


@pytest.mark.parametrize(("kind", "nbytes"), [("zstd", GIB), ("lz4", GIB), ("bz2", 1 << 26)])
def test_a_bomb_inflates_to_its_declared_size_only(kind: str, nbytes: int) -> None:
    # the zstd frame says 1 GiB itself; the chunk header says 1 MiB: 1 MiB is all we get
    got = inflate(kind, _zeros_frame(kind, nbytes), 1 << 20)
    assert len(got.data) == 1 << 20
    assert "more than the declared 1048576 bytes" in got.error


@pytest.mark.parametrize("kind", ["zstd", "lz4", "bz2", "none"])
def test_inflate_round_trips_and_keeps_the_start_of_a_cut_stream(kind: str) -> None:
    rng = random.Random(4)
    data = bytes(rng.randrange(8) for _ in range(400_000))  # bz2: four 100 kB blocks
    packed = {"zstd": zstandard.ZstdCompressor().compress, "lz4": lz4.frame.compress,
              "bz2": lambda d: bz2.compress(d, 1), "none": bytes}[kind](data)
    whole = inflate(kind, packed, len(data))
    assert whole.data == data and whole.error == ""
    cut = inflate(kind, packed[: len(packed) * 2 // 3], len(data))
    assert cut.error and 0 < len(cut.data) < len(data)
    assert data.startswith(cut.data)


def test_a_chunk_declaring_more_than_the_limit_is_not_decompressed() -> None:
    got = inflate("zstd", _zeros_frame("zstd", 1 << 24), MAX_CHUNK_BYTES + 1)
    assert got.data == b"" and "above the limit" in got.error


def _pymavlink_offsets(data: bytes) -> list[list[int]]:
    from pymavlink import dfindexer

    return [list(o) for o in dfindexer.build_offsets(memoryview(data), 0x80, 89, 3, 4,
                                                      0xA3, 0x95)]


def _index(data: bytes) -> tuple[list[list[int]], dataflash_index.IndexStats]:
    stats = dataflash_index.IndexStats()
    token = dataflash_index.STATS.set(stats)
    try:
        return dataflash_index.build_offsets(memoryview(data), 0x80, 89, 3, 4, 0xA3,
                                             0x95), stats
    finally:
        dataflash_index.STATS.reset(token)


@pytest.mark.parametrize("log", [BIN, ROOT.parent / "shared" / "data" / "logs" /
                                 "ardupilot_copter33_loiter_acro_flips_real.bin"])
def test_the_dataflash_indexer_equals_pymavlinks_on_a_real_log(log: Path) -> None:
    if not log.exists():  # ../shared is the workplace's data, not in a user's clone
        pytest.skip(f"{log} not available")
    data = log.read_bytes()
    offsets, stats = _index(data)
    assert offsets == _pymavlink_offsets(data)
    assert stats.skipped_bytes == 0 and stats.rejected_fmts == []


def _bad_fmt(kind: int, length: int) -> bytes:
    return b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", kind, length, b"BAD", b"B", b"Bad")


def test_an_fmt_of_length_0_at_the_start_costs_only_itself() -> None:
    data = BIN.read_bytes()
    offsets, stats = _index(_bad_fmt(200, 0) + data)
    assert offsets == [[o + 89 for o in per] for per in _pymavlink_offsets(data)]
    assert stats.rejected_fmts == [0]
    assert sum(map(len, _pymavlink_offsets(_bad_fmt(200, 0) + data))) == 0  # pymavlink: none


def test_garbage_in_the_middle_is_skipped_to_the_next_message() -> None:
    data = BIN.read_bytes()
    clean, _ = _index(data)
    starts = sorted(o for per in clean for o in per)
    cut = starts[len(starts) // 2]
    garbage = random.Random(1).randbytes(50_000).replace(b"\xa3\x95", b"\x00\x00")
    offsets, stats = _index(data[:cut] + garbage + data[cut:])
    assert stats.skipped_bytes == len(garbage) and stats.stretches == 1
    moved = [[o if o < cut else o + len(garbage) for o in per] for per in clean]
    assert offsets == moved


def test_ulog_recursive_formats_are_found_with_what_depends_on_them(tmp_path: Path) -> None:
    formats = [b"a:uint64_t timestamp;b x;", b"b:uint64_t timestamp;a y;",  # a cycle
               b"c:uint64_t timestamp;a z[2];",  # depends on it
               b"self:uint64_t timestamp;self next;", b"fine:uint64_t timestamp;float v;"]
    body = b"".join(struct.pack("<HB", len(f), ord("F")) + f for f in formats)
    path = tmp_path / "r.ulg"
    head = ULG.read_bytes()[:16]
    path.write_bytes(head + body)
    cleaned = ulog_clean.clean(path)
    assert cleaned.recursive == ["a", "b", "c", "self"]
    new = ulog_clean.payload(path, cleaned)
    assert b"a:uint64_t timestamp;" in new and b"self next" not in new
    assert b"fine:uint64_t timestamp;float v;" in new


def test_ulog_clean_leaves_a_real_log_alone_and_drops_a_tail_of_zeros(
        tmp_path: Path) -> None:
    assert not ulog_clean.clean(ULG).changed
    path = tmp_path / "tail.ulg"
    path.write_bytes(ULG.read_bytes() + bytes(100_000))
    cleaned = ulog_clean.clean(path)
    assert cleaned.tail == 100_000 and cleaned.spans == [(0, ULG.stat().st_size)]


def test_one_undecodable_db3_message_costs_only_itself(tmp_path: Path) -> None:
    import shutil

    bag = tmp_path / "bag"
    shutil.copytree(ROOT / "sample_logs" / "hexa_ige_oge_db3", bag)
    with sqlite3.connect(bag / "hexa_ige_oge_db3.db3") as db:
        tid = db.execute("SELECT id FROM topics WHERE name='/mavros/imu/data'").fetchone()[0]
        row, stamp = db.execute("SELECT id, timestamp FROM messages WHERE topic_id=? "
                                "ORDER BY id LIMIT 1 OFFSET 500", (tid,)).fetchone()
        first = db.execute("SELECT MIN(timestamp) FROM messages").fetchone()[0]
        db.execute("UPDATE messages SET data=x'00010000000000000000' WHERE id=?", (row,))
    clean = read_log(ROOT / "sample_logs" / "hexa_ige_oge_db3")
    table = read_log(bag)
    assert {"p", "q", "r", "roll", "pitch", "yaw"} <= set(table.columns)
    assert len(table) >= len(clean) - 1  # the grid follows the IMU clock
    note = next(w for w in table.attrs["warnings"] if w.startswith("/mavros/imu/data:"))
    assert f"1 of {3000} message(s) could not be decoded" in note
    assert f"t = {(stamp - first) * 1e-9:.1f} s" in note


def test_printable_shows_every_terminal_control() -> None:
    shown = printable("a\x1b[2J\x07\x9b\r\n\u202eb\tc")
    assert all(ch not in shown for ch in "\x1b\x07\x9b\r\n\u202e\t")
    assert shown == "a\\x1b[2J\\x07\\x9b\\x0d\\x0a\\u202eb\\x09c"


def test_mapped_find_releases_pages_and_still_finds(tmp_path: Path) -> None:
    from etsid.ingest import mapped

    path = tmp_path / "z"
    with path.open("wb") as out:
        out.truncate(200 << 20)
        out.seek(150 << 20)
        out.write(b"needle")
    with path.open("rb") as handle, mmap.mmap(handle.fileno(), 0,
                                              access=mmap.ACCESS_READ) as mm:
        assert mapped.find(mm, b"needle", 0) == 150 << 20
        assert mapped.find(mm, b"needle", (150 << 20) + 1) == -1
