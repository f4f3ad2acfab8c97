"""Structure-aware hostile inputs: files built with the real writers, then edited.

Byte flips (:mod:`mutants`) rarely make a decompression bomb, a format that refers to
itself or one bad message among thousands. Each case here builds such a file in a work
folder (rosbags, mcap and pymavlink-made sample logs rewritten with their own writers, then
one structure edited) and says what a correct run gives: a table holding the columns the
valid part carries, with a note naming what was lost, or one ``etsid: error:`` line.

:func:`run_case` runs ``etsid`` in a child process, kills it past the time bound or past
the memory bound (resident set, polled), and returns the verdict with its time and peak
memory. ``python benchmarks/fuzz.py --structure`` runs every case; tests/fuzz/
test_structure.py runs the cheap ones.
"""

from __future__ import annotations

import bz2
import contextlib
import json
import os
import random
import shutil
import signal
import sqlite3
import struct
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample_logs"
DATA = ROOT / "tests" / "data"
TIME_BOUND_S = 30.0
MEMORY_BOUND_MB = 1024.0
RATES = ("p", "q", "r", "roll", "pitch", "yaw")
GIB = 1 << 30
ZEROS_BYTES = 2 * GIB
"""Zeros after a valid start (sparse files: no disk); CI uses less."""


@dataclass
class Case:
    """One hostile input: how to build it and what a correct run gives.

    ``args`` are the ``etsid`` arguments with ``{in}`` for the built path and ``{out}``
    for a table to write; ``columns``: a table must be written holding these columns;
    ``note``: strings the run's output (stdout+stderr) must contain; ``error``: the run
    must end in one ``etsid: error:`` line instead; ``absent``: strings the output must
    not contain (raw terminal escapes); ``rows``: the fewest rows the table may have (the
    valid part of the file gives them); ``cheap``: run in CI (tests/fuzz/
    test_structure.py).
    """

    name: str
    build: Callable[[Path], Path]
    args: tuple[str, ...] = ("ingest", "{in}", "-o", "{out}")
    columns: tuple[str, ...] = ()
    note: tuple[str, ...] = ()
    error: bool = False
    absent: tuple[str, ...] = ()
    rows: int = 0
    cheap: bool = False
    what: str = ""
    seconds: float = 0.0
    """Time bound of this case, s (0: :data:`TIME_BOUND_S`)."""
    check: Callable[[Path, Path, str], str] | None = None
    """``check(out, built, output)``: what is wrong with what a successful run wrote ("" if
    nothing); ``out`` is ``{out}``, ``built`` the built input, ``output`` stdout+stderr."""


@dataclass
class Verdict:
    """How one run ended against its case."""

    case: str
    ok: bool
    detail: str
    seconds: float
    peak_mb: float
    lines: list[str] = field(default_factory=list)


# ---------------------------------------------------------------------------
# ROS: one bad message among many


def _db3_one_bad(work: Path) -> Path:
    bag = work / "db3_one_bad"
    shutil.copytree(SAMPLES / "hexa_ige_oge_db3", bag)
    db = sqlite3.connect(bag / "hexa_ige_oge_db3.db3")
    tid = db.execute("SELECT id FROM topics WHERE name='/mavros/imu/data'").fetchone()[0]
    row = db.execute("SELECT id FROM messages WHERE topic_id=? ORDER BY id LIMIT 1 OFFSET 1000",
                     (tid,)).fetchone()[0]
    db.execute("UPDATE messages SET data=x'00010000000000000000' WHERE id=?", (row,))
    db.commit()
    db.close()
    return bag


def _db3_flood(work: Path, count: int = 300_000) -> Path:
    """The sample db3 bag with ``count`` empty IMU messages after the flight (1 µs apart),
    metadata.yaml's counts raised to match."""
    import yaml

    bag = work / "db3_flood"
    shutil.copytree(SAMPLES / "hexa_ige_oge_db3", bag)
    with sqlite3.connect(bag / "hexa_ige_oge_db3.db3") as db:
        tid = db.execute("SELECT id FROM topics WHERE name='/mavros/imu/data'").fetchone()[0]
        last = db.execute("SELECT MAX(timestamp) FROM messages").fetchone()[0]
        db.executemany("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, x'')",
                       ((tid, last + 1000 * (i + 1)) for i in range(count)))
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())
    info = meta["rosbag2_bagfile_information"]
    info["message_count"] += count
    info["files"][0]["message_count"] += count
    info["duration"]["nanoseconds"] += 1000 * count
    info["files"][0]["duration"]["nanoseconds"] += 1000 * count
    for entry in info["topics_with_message_count"]:
        if entry["topic_metadata"]["name"] == "/mavros/imu/data":
            entry["message_count"] += count
    (bag / "metadata.yaml").write_text(yaml.safe_dump(meta))
    return bag


def _mcap_messages(src: Path):  # type: ignore[no-untyped-def]
    from mcap.reader import make_reader

    with src.open("rb") as handle:
        yield from make_reader(handle).iter_messages()


def _rewrite_mcap(src: Path, dst: Path, edit: Callable[[str, int, bytes], bytes | None],
                  chunk_size: int = 1 << 20, extra=None) -> Path:  # type: ignore[no-untyped-def]
    """``src`` rewritten with mcap's writer; ``edit(topic, index in topic, data)`` gives the
    new body of a message (None: unchanged)."""
    from mcap.writer import Writer

    seen: dict[str, int] = {}
    schemas: dict[int, int] = {}
    channels: dict[int, int] = {}
    with dst.open("wb") as out:
        writer = Writer(out, chunk_size=chunk_size)
        writer.start("ros2", "etsid structure fuzzer")
        for schema, channel, message in _mcap_messages(src):
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding,
                                                            schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id],
                    channel.metadata)
            k = seen[channel.topic] = seen.get(channel.topic, -1) + 1
            data = edit(channel.topic, k, message.data)
            writer.add_message(channels[channel.id], message.log_time,
                               message.data if data is None else data, message.publish_time)
            if extra is not None:
                extra(writer, schemas, message)
        writer.finish()
    return dst


def _mcap_one_bad(work: Path) -> Path:
    def edit(topic: str, k: int, data: bytes) -> bytes | None:
        return b"\x00\x01" + bytes(8) if topic == "/mavros/imu/data" and k == 1000 else None

    return _rewrite_mcap(SAMPLES / "hexa_ige_oge.mcap", work / "one_bad.mcap", edit)


def _mcap_frame_id(work: Path) -> Path:
    def edit(topic: str, k: int, data: bytes) -> bytes | None:
        if topic != "/mavros/imu/data" or k != 1000:
            return None
        # CDR: 4-byte encapsulation, stamp (8 bytes), then frame_id's uint32 length
        return data[:12] + struct.pack("<I", 0x7FFFFFF0) + data[16:]

    return _rewrite_mcap(SAMPLES / "hexa_ige_oge.mcap", work / "frame_id.mcap", edit)


def _bag_rewrite(src: Path, dst: Path, edit: Callable[[str, int, bytes], bytes | None],
                 compression: str = "lz4", threshold: int | None = None,
                 flood: int = 0) -> Path:
    """``src`` rewritten with rosbags' writer; ``edit`` as for :func:`_rewrite_mcap`;
    ``flood``: this many empty IMU messages appended at the last record time."""
    from rosbags.rosbag1 import Reader, Writer

    seen: dict[str, int] = {}
    writer = Writer(dst)
    writer.set_compression(getattr(Writer.CompressionFormat, compression.upper()))
    if threshold is not None:
        writer.chunk_threshold = threshold
    with Reader(src) as reader, writer:
        conns = {c.id: writer.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data,
                                             md5sum=c.digest) for c in reader.connections}
        last = 0
        for conn, stamp, data in reader.messages():
            k = seen[conn.topic] = seen.get(conn.topic, -1) + 1
            new = edit(conn.topic, k, data)
            writer.write(conns[conn.id], stamp, data if new is None else new)
            last = max(last, stamp)
        imu = next(c for c in reader.connections if c.topic == "/mavros/imu/data")
        for _ in range(flood):
            writer.write(conns[imu.id], last, b"")
    return dst


def _bag_one_bad(work: Path) -> Path:
    def edit(topic: str, k: int, data: bytes) -> bytes | None:
        return bytes(10) if topic == "/mavros/imu/data" and k == 1000 else None

    return _bag_rewrite(SAMPLES / "hexa_ige_oge.bag", work / "one_bad.bag", edit)


def _bag_flood(work: Path) -> Path:
    return _bag_rewrite(SAMPLES / "hexa_ige_oge.bag", work / "flood.bag", lambda *_: None,
                        flood=500_000)


# ---------------------------------------------------------------------------
# MCAP: decompression bombs and channel floods


def _zstd_zeros(nbytes: int, content_size: bool = True) -> bytes:
    import zstandard

    cctx = zstandard.ZstdCompressor(level=1, write_content_size=content_size)
    obj = cctx.compressobj(size=nbytes if content_size else -1)
    block = bytes(1 << 24)
    out = bytearray()
    for _ in range(nbytes // len(block)):
        out += obj.compress(block)
    out += obj.compress(bytes(nbytes % len(block)))
    out += obj.flush()
    return bytes(out)


def _lz4_zeros(nbytes: int) -> bytes:
    import lz4.frame

    comp = lz4.frame.LZ4FrameCompressor()
    out = bytearray(comp.begin())
    block = bytes(1 << 24)
    for _ in range(nbytes // len(block)):
        out += comp.compress(block)
    out += comp.compress(bytes(nbytes % len(block)))
    out += comp.flush()
    return bytes(out)


def _mcap_string(text: str) -> bytes:
    raw = text.encode()
    return struct.pack("<I", len(raw)) + raw


def _chunk_record(compression: str, data: bytes, declared: int, start_ns: int,
                  end_ns: int) -> bytes:
    body = (struct.pack("<QQQI", start_ns, end_ns, declared, 0) + _mcap_string(compression)
            + struct.pack("<Q", len(data)) + data)
    return struct.pack("<BQ", 6, len(body)) + body


def _insert_before_data_end(src: bytes, records: bytes) -> bytes:
    """MCAP bytes with ``records`` put just before the DataEnd record (summary offsets
    in the footer moved along, summary CRC cleared)."""
    pos = 8
    while pos < len(src):
        op, length = struct.unpack_from("<BQ", src, pos)
        if op == 0x0F:
            break
        pos += 9 + length
    out = bytearray(src[:pos] + records + src[pos:])
    footer = len(out) - 8 - 29
    summary, offsets, _ = struct.unpack_from("<QQI", out, footer + 9)
    struct.pack_into("<QQI", out, footer + 9, summary + len(records) if summary else 0,
                     offsets + len(records) if offsets else 0, 0)
    return bytes(out)


def _small_mcap(work: Path, name: str) -> tuple[Path, int, int]:
    """The sample MCAP rewritten with 64 KiB chunks; (path, first and last log time)."""
    path = _rewrite_mcap(SAMPLES / "hexa_ige_oge.mcap", work / name,
                         lambda *_: None, chunk_size=64 << 10)
    times = [m.log_time for _, _, m in _mcap_messages(path)]
    return path, min(times), max(times)


def _mcap_bomb(kind: str, nbytes: int, declared: int | None = None,
               count: int = 1) -> Callable[[Path], Path]:
    def build(work: Path) -> Path:
        path, lo, hi = _small_mcap(work, f"bomb_{kind}.mcap")
        data = _zstd_zeros(nbytes) if kind == "zstd" else _lz4_zeros(nbytes)
        size = nbytes if declared is None else declared
        chunk = _chunk_record(kind, data, size, lo, hi)
        path.write_bytes(_insert_before_data_end(path.read_bytes(), chunk * count))
        return path

    return build


def _mcap_message_bomb(work: Path, nbytes: int = GIB) -> Path:
    """A zstd chunk of 31-byte message records (empty bodies on the IMU channel) that
    inflates to ``nbytes``, among the valid chunks."""
    import zstandard

    path, lo, hi = _small_mcap(work, "message_bomb.mcap")
    channel = _channel_id(path, "/mavros/imu/data")
    record = struct.pack("<BQHIQQ", 5, 22, channel, 0, lo, lo)
    block = record * ((1 << 24) // len(record))
    total = (nbytes // len(block)) * len(block)
    obj = zstandard.ZstdCompressor(level=1).compressobj(size=total)
    data = bytearray()
    for _ in range(total // len(block)):
        data += obj.compress(block)
    data += obj.flush()
    chunk = _chunk_record("zstd", bytes(data), total, lo, hi)
    path.write_bytes(_insert_before_data_end(path.read_bytes(), chunk))
    return path


def _mcap_huge_message(work: Path) -> Path:
    """The sample MCAP rewritten with 64 KiB chunks and, before its DataEnd record, one
    message record declaring :data:`ZEROS_BYTES` of body (a sparse hole)."""
    path, lo, _ = _small_mcap(work, "huge_message.mcap")
    src = path.read_bytes()
    pos = 8
    while True:
        op, length = struct.unpack_from("<BQ", src, pos)
        if op == 0x0F:
            break
        pos += 9 + length
    channel = _channel_id(path, "/mavros/imu/data")
    head = struct.pack("<BQHIQQ", 5, 22 + ZEROS_BYTES, channel, 0, lo, lo)
    with path.open("r+b") as out:
        out.seek(pos)
        out.write(head)
        out.seek(pos + len(head) + ZEROS_BYTES)
        out.write(src[pos:])
    return path


def _mcap_channel_flood(work: Path, channels: int = 60_000) -> Path:
    """The sample MCAP with ``channels`` extra channels, each registered (and so written)
    between messages."""
    state = {"n": 0}

    def extra(writer, schemas, message) -> None:  # type: ignore[no-untyped-def]
        for _ in range(min(channels - state["n"], 8)):
            state["n"] += 1
            cid = writer.register_channel(f"/flood/{state['n']}", "cdr", next(iter(
                schemas.values())))
            writer.add_message(cid, message.log_time, b"\x00\x01\x00\x00", message.log_time)

    return _rewrite_mcap(SAMPLES / "hexa_ige_oge.mcap", work / "channels.mcap",
                         lambda *_: None, extra=extra)


ESCAPES = ("/x\x1b]52;c;ZWNobyBwd25lZA==\x07", "/y\x1b[2J\x1b[31m<script>", "/z\x9b1m\r\x08")
"""Topic names carrying OSC 52 (clipboard), CSI and other control characters."""


def _mcap_escape_topic(work: Path) -> Path:
    """The sample MCAP with three more channels named with terminal escapes: one copies
    every IMU message (a usable candidate for p, q, r), two hold an undecodable message."""
    state: dict[str, int] = {}

    def extra(writer, schemas, message) -> None:  # type: ignore[no-untyped-def]
        if not state:
            schema = next(iter(schemas.values()))
            for name in ESCAPES:
                state[name] = writer.register_channel(name, "cdr", schema)
            for name in ESCAPES[1:]:
                writer.add_message(state[name], message.log_time, b"\x00\x01\x00\x00",
                                   message.log_time)
        if message.channel_id == imu:
            writer.add_message(state[ESCAPES[0]], message.log_time, message.data,
                               message.log_time)

    imu = _channel_id(SAMPLES / "hexa_ige_oge.mcap", "/mavros/imu/data")
    return _rewrite_mcap(SAMPLES / "hexa_ige_oge.mcap", work / "escapes.mcap",
                         lambda *_: None, extra=extra)


def _mcap_escape_only(work: Path) -> Path:
    """An MCAP file whose only channels (std_msgs/String) are named with escapes and a
    newline: nothing to ingest, and the error names them."""
    from mcap.writer import Writer

    path = work / "escape_only.mcap"
    with path.open("wb") as out:
        writer = Writer(out)
        writer.start("ros2", "etsid structure fuzzer")
        schema = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        for name in (*ESCAPES, "/~\nnote: forged line"):
            cid = writer.register_channel(name, "cdr", schema)
            for i in range(10):
                writer.add_message(cid, 1_000_000_000 * (i + 1), b"\x00\x01\x00\x00"
                                   + struct.pack("<I", 2) + b"a\x00", 1_000_000_000 * (i + 1))
        writer.finish()
    return path


def _channel_id(path: Path, topic: str) -> int:
    """The id of ``topic``'s channel in the MCAP file ``path``."""
    from mcap.reader import make_reader

    with path.open("rb") as handle:
        summary = make_reader(handle).get_summary()
    return next(c.id for c in summary.channels.values() if c.topic == topic)


# ---------------------------------------------------------------------------
# ROS 1: bz2 bomb, magic + zeros


def _ros1_records(buf: bytes, pos: int) -> list[tuple[int, dict[str, bytes], int, int]]:
    """Top-level records: (start, header fields, data start, data length)."""
    out = []
    while pos + 4 <= len(buf):
        (hlen,) = struct.unpack_from("<I", buf, pos)
        fields, at = {}, pos + 4
        while at < pos + 4 + hlen:
            (flen,) = struct.unpack_from("<I", buf, at)
            key, _, value = buf[at + 4:at + 4 + flen].partition(b"=")
            fields[key.decode()] = value
            at += 4 + flen
        (dlen,) = struct.unpack_from("<I", buf, at)
        out.append((pos, fields, at + 4, dlen))
        pos = at + 4 + dlen
    return out


def _bag_bz2_bomb(work: Path) -> Path:
    """The sample bag rewritten with bz2 chunks of 64 KiB; its last chunk replaced by one
    of 1.5 GiB of zeros (declared as such), the bag header's index position moved along."""
    path = _bag_rewrite(SAMPLES / "hexa_ige_oge.bag", work / "bz2_bomb.bag",
                        lambda *_: None, compression="bz2", threshold=64 << 10)
    buf = bytearray(path.read_bytes())
    records = _ros1_records(bytes(buf), 13)
    header = records[0]
    (index_pos,) = struct.unpack("<Q", header[1]["index_pos"])
    last = max(r for r in records if r[1].get("op") == b"\x05" and r[0] < index_pos)
    start, _, data_at, dlen = last
    comp = bz2.BZ2Compressor(9)
    block = bytes(1 << 24)
    bomb = b"".join(comp.compress(block) for _ in range(96)) + comp.flush()
    hdr = bytearray(buf[start + 4:data_at - 4])
    size_at = hdr.find(b"size=") + 5
    struct.pack_into("<I", hdr, size_at, 96 << 24)
    new = struct.pack("<I", len(hdr)) + bytes(hdr) + struct.pack("<I", len(bomb)) + bomb
    delta = len(new) - (data_at + dlen - start)
    buf[start:data_at + dlen] = new
    pos = bytes(buf).find(b"index_pos=", 13) + 10
    struct.pack_into("<Q", buf, pos, index_pos + delta)
    path.write_bytes(bytes(buf))
    return path


def _sparse_after(prefix: bytes, name: str) -> Callable[[Path], Path]:
    """``prefix`` followed by :data:`ZEROS_BYTES` of zeros (a sparse file)."""
    def build(work: Path) -> Path:
        path = work / name
        with path.open("wb") as out:
            out.write(prefix)
            out.truncate(len(prefix) + ZEROS_BYTES)  # sparse: costs no disk
        return path

    return build


def _bag_magic_zeros(work: Path) -> Path:
    head = (SAMPLES / "hexa_ige_oge.bag").read_bytes()[:13 + 4096 + 8]
    return _sparse_after(head, "zeros.bag")(work)


def _ulog_zeros(work: Path) -> Path:
    head = (DATA / "px4_cubeorange_real.ulg").read_bytes()[:16]
    return _sparse_after(head, "zeros.ulg")(work)


# ---------------------------------------------------------------------------
# ULog: a format that refers to itself


def _ulog_messages(buf: bytes) -> list[tuple[int, int, int]]:
    """(start, size, type) of each message after the 16-byte header."""
    out, pos = [], 16
    while pos + 3 <= len(buf):
        size, kind = struct.unpack_from("<HB", buf, pos)
        out.append((pos, size, kind))
        pos += 3 + size
    return out


def _ulog_recursive(work: Path) -> Path:
    """The real PX4 log with one more format, ``loop``, holding a field of type ``loop``,
    put among its definitions, and a subscription to it before the first one."""
    buf = (DATA / "px4_cubeorange_real.ulg").read_bytes()
    msgs = _ulog_messages(buf)
    first_format = next(m for m in msgs if m[2] == ord("F"))[0]
    first_add = next(m for m in msgs if m[2] == ord("A"))[0]
    fmt = b"loop:uint64_t timestamp;loop next;"
    add = b"\x00" + struct.pack("<H", 999) + b"loop"
    path = work / "recursive.ulg"
    path.write_bytes(buf[:first_format] + struct.pack("<HB", len(fmt), ord("F")) + fmt
                     + buf[first_format:first_add] + struct.pack("<HB", len(add), ord("A"))
                     + add + buf[first_add:])
    return path


def _ulog_garbage_defs(work: Path) -> Path:
    """The real PX4 log with 20 MiB of random bytes among its definitions (before the
    last format message), where pyulog steps through garbage a byte at a time."""
    buf = (DATA / "px4_cubeorange_real.ulg").read_bytes()
    at = [m for m in _ulog_messages(buf) if m[2] == ord("F")][-1][0]
    garbage = random.Random(5).randbytes(20 << 20)
    path = work / "garbage_defs.ulg"
    path.write_bytes(buf[:at] + garbage + buf[at:])
    return path


# ---------------------------------------------------------------------------
# DataFlash


def _bin_records(buf: bytes) -> list[int]:
    """Offsets of the messages of a DataFlash log, from its FMT lengths."""
    lengths: dict[int, int] = {128: 89}
    out, pos = [], 0
    while pos + 3 <= len(buf):
        if buf[pos] != 0xA3 or buf[pos + 1] != 0x95:
            break
        kind = buf[pos + 2]
        if kind == 128:
            lengths[buf[pos + 3]] = buf[pos + 4]
        size = lengths.get(kind)
        if size is None or size < 3:
            break
        out.append(pos)
        pos += size
    return out


def _bin_fmt(kind: int, length: int, name: bytes) -> bytes:
    return (b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", kind, length, name, b"B",
                                          b"Bad"))


def _bin_with(at_fraction: float, insert: bytes, name: str) -> Callable[[Path], Path]:
    def build(work: Path) -> Path:
        buf = (DATA / "arduplane_truncated.BIN").read_bytes()
        starts = _bin_records(buf)
        at = 0 if at_fraction == 0 else starts[int(len(starts) * at_fraction)]
        path = work / name
        path.write_bytes(buf[:at] + insert + buf[at:])
        return path

    return build


def _bin_garbage(work: Path) -> Path:
    rng = random.Random(23)
    return _bin_with(0.5, rng.randbytes(20 << 20), "garbage.BIN")(work)


def _bin_zeros(work: Path) -> Path:
    buf = (DATA / "arduplane_truncated.BIN").read_bytes()
    return _sparse_after(buf, "zeros.BIN")(work)


# ---------------------------------------------------------------------------
# tables and rule bases


def _csv_wide(work: Path, cols: int = 1_000_000) -> Path:
    """A CSV table of ``cols`` columns and one row."""
    path = work / "wide.csv"
    with path.open("w") as out:
        out.write(",".join(f"c{i}" for i in range(cols)) + "\n")
        out.write(",".join("0" for _ in range(cols)) + "\n")
    return path


def _link(target: str, name: str) -> Callable[[Path], Path]:
    def build(work: Path) -> Path:
        path = work / name
        path.symlink_to(target)
        return path

    return build


def _fifo(name: str) -> Callable[[Path], Path]:
    def build(work: Path) -> Path:
        path = work / name
        os.mkfifo(path)
        return path

    return build


def _bag_dir_fifo(work: Path) -> Path:
    """The sample db3 bag directory with its storage file replaced by a FIFO."""
    bag = work / "fifo_bag"
    shutil.copytree(SAMPLES / "hexa_ige_oge_db3", bag)
    (bag / "hexa_ige_oge_db3.db3").unlink()
    os.mkfifo(bag / "hexa_ige_oge_db3.db3")
    return bag


def _rules_doc() -> dict:
    """The fields of a rule base that size its arrays: one input, one output, one rule."""
    return {
        "schema": "etsid.rules/2", "inputs": ["y[k-1]"], "outputs": ["y"],
        "antecedents": {"scheduled": False, "names": ["y[k-1]"], "dimension": 1},
        "params": {"max_rules": 10},
        "rules": [{"id": 0, "focal_point": [0.0, 0.0], "radius": [0.5], "scatter": [0.1],
                   "consequent": [[0.0], [1.0]]}],
    }


def _rules_focal(count: int) -> Callable[[Path], Path]:
    """A rules.json whose focal point holds ``count`` numbers."""
    def build(work: Path) -> Path:
        path = work / "rules.json"
        head, _, tail = json.dumps(_rules_doc()).partition('"focal_point": [0.0, 0.0]')
        with path.open("w") as out:
            out.write(head + '"focal_point": [')
            out.write(",".join(["0"] * count))
            out.write("]" + tail)
        return path

    return build


def _rules_keys(work: Path) -> Path:
    """A rules.json that is one object of 4 million keys."""
    path = work / "rules.json"
    with path.open("w") as out:
        out.write("{" + ",".join(f'"k{i}":0' for i in range(4_000_000)) + "}")
    return path


# ---------------------------------------------------------------------------
# the cases


CASES: list[Case] = [
    Case("db3-one-bad-imu", _db3_one_bad, columns=RATES, note=("/mavros/imu/data",),
         cheap=True, rows=2900, what="ROS 2 db3: one 10-byte IMU message among 3000"),
    Case("db3-message-flood", _db3_flood, columns=RATES, rows=2900,
         note=("could not be decoded",),
         what="ROS 2 db3: 300 000 empty IMU messages after the flight"),
    Case("mcap-one-bad-imu", _mcap_one_bad, columns=RATES, note=("/mavros/imu/data",),
         cheap=True, rows=11900, what="MCAP: one 10-byte IMU message among 12000"),
    Case("mcap-frame-id-length", _mcap_frame_id, columns=RATES, note=("/mavros/imu/data",),
         rows=11900,
         what="MCAP: one IMU frame_id length set to 2^31 (CRC recomputed by the writer)"),
    Case("bag-one-bad-imu", _bag_one_bad, columns=RATES, note=("/mavros/imu/data",),
         cheap=True, rows=11900, what="ROS 1 bag: one 10-byte IMU message among 12000"),
    Case("mcap-zstd-bomb", _mcap_bomb("zstd", 4 * GIB, declared=1 << 20), columns=RATES,
         note=("chunk",), cheap=True,
         rows=11900, what="MCAP: a 4 GiB zstd frame of zeros (frame says so) declared as 1 MiB"),
    Case("mcap-lz4-bomb", _mcap_bomb("lz4", 4 * GIB, declared=1 << 20), columns=RATES,
         note=("chunk",), rows=11900, what="MCAP: a 4 GiB lz4 frame of zeros declared as 1 MiB"),
    Case("mcap-zero-chunks", _mcap_bomb("zstd", GIB - (1 << 24), count=10), columns=RATES,
         note=("chunk",), rows=11900,
         what="MCAP: ten zstd chunks of 1 GiB of zeros each, declared so"),
    Case("mcap-zero-chunks-127m", _mcap_bomb("zstd", 127 << 20, count=10), columns=RATES,
         note=("chunk",), rows=11900,
         what="MCAP: ten zstd chunks of 127 MiB of zeros each (under the limit), declared so"),
    Case("mcap-message-bomb", _mcap_message_bomb, columns=RATES, note=("chunk",),
         rows=11900, what="MCAP: a chunk of 31-byte message records inflating to 1 GiB beside the "
              "valid chunks"),
    Case("mcap-message-flood", lambda work: _mcap_message_bomb(work, 120 << 20),
         columns=RATES, rows=11900, note=("could not be decoded",),
         what="MCAP: a chunk of 4 million empty IMU messages (120 MiB, under the chunk "
              "limit) beside the valid chunks"),
    Case("mcap-huge-message", _mcap_huge_message, columns=RATES, rows=11900,
         note=("damaged",),
         what="MCAP: a message record of 2 GiB (zeros, sparse) before the summary"),
    Case("mcap-channel-flood", _mcap_channel_flood, columns=RATES,
         rows=11900, what="MCAP: 60 000 channel records interleaved with the messages"),
    Case("bag-message-flood", _bag_flood, columns=RATES, rows=11900,
         note=("could not be decoded",),
         what="ROS 1 bag: 500 000 empty IMU messages after the flight"),
    Case("bag-bz2-bomb", _bag_bz2_bomb, columns=RATES, note=("chunk",),
         rows=11000, what="ROS 1 bag: last bz2 chunk replaced by 1.5 GiB of zeros"),
    Case("bag-magic-zeros", _bag_magic_zeros, error=True,
         what="ROS 1 bag: valid magic and header, then 2 GiB of zeros (sparse)"),
    Case("ulog-zeros", _ulog_zeros, error=True,
         what="ULog: valid header, then 2 GiB of zeros (sparse)"),
    Case("ulog-recursive-format", _ulog_recursive, columns=RATES, note=("loop",), cheap=True,
         rows=1800,
         what="ULog: a format with a field of its own type among the real log's formats"),
    Case("ulog-garbage-defs", _ulog_garbage_defs, columns=RATES, rows=1800,
         note=("corrupt",),
         what="ULog: 20 MiB of random bytes among the format definitions"),
    Case("bin-fmt0-start", _bin_with(0, _bin_fmt(200, 0, b"BAD0"), "fmt0.BIN"),
         columns=("roll", "pitch", "yaw"), note=("FMT",), cheap=True,
         rows=40, what="DataFlash: an FMT of length 0 before the first message"),
    Case("bin-fmt1-mid", _bin_with(0.5, _bin_fmt(201, 1, b"BAD1"), "fmt1.BIN"),
         columns=("roll", "pitch", "yaw"), note=("FMT",), cheap=True,
         rows=40, what="DataFlash: an FMT of length 1 in the middle of the log"),
    Case("bin-garbage-20mb", _bin_garbage, columns=("roll", "pitch", "yaw"),
         note=("no valid DataFlash message",),
         rows=40, what="DataFlash: 20 MiB of random bytes in the middle"),
    Case("bin-zeros", _bin_zeros, columns=("roll", "pitch", "yaw"), cheap=True,
         note=("no valid DataFlash message",),
         rows=40, what="DataFlash: the log followed by 2 GiB of zeros (sparse)"),
    Case("csv-million-columns", _csv_wide, error=True,
         args=("identify", "{in}", "--output", "c1", "--regressors", "c1[k-1]",
               "--out", "{out}"),
         what="CSV table of 10^6 columns"),
    Case("csv-20k-columns", lambda work: _csv_wide(work, 20_000), error=True,
         args=("identify", "{in}", "--output", "c1", "--regressors", "c1[k-1]",
               "--out", "{out}"), note=("columns",),
         what="CSV table of 20 000 columns (a header line under 1 MiB)"),
    Case("csv-dev-zero", _link("/dev/zero", "x.csv"), error=True,
         args=("identify", "{in}", "--output", "y", "--regressors", "y[k-1]", "--out",
               "{out}"), what="x.csv → /dev/zero"),
    Case("csv-fifo", _fifo("fifo.csv"), error=True, cheap=True,
         args=("identify", "{in}", "--output", "y", "--regressors", "y[k-1]", "--out",
               "{out}"), what="a FIFO named fifo.csv"),
    Case("log-fifo", _fifo("fifo.tlog"), error=True, cheap=True, what="a FIFO named .tlog"),
    Case("bag-dir-fifo", _bag_dir_fifo, error=True, cheap=True,
         what="a ROS 2 bag directory whose .db3 storage file is a FIFO"),
    Case("rules-fifo", _fifo("rules.json"), error=True, args=("rules", "{in}"),
         what="etsid rules FIFO"),
    Case("rules-dev-zero", _link("/dev/zero", "rules.json"), error=True, cheap=True,
         args=("rules", "{in}"), what="etsid rules → /dev/zero"),
    Case("rules-30m-focal", _rules_focal(30_000_000), error=True, args=("rules", "{in}"),
         what="rules.json of 60 MB: a focal point of 30 million numbers"),
    Case("rules-3m-focal", _rules_focal(3_000_000), error=True, args=("rules", "{in}"),
         note=("focal_point",), cheap=True,
         what="rules.json of 6 MB: a focal point of 3 million numbers (under the value cap)"),
    Case("rules-4m-keys", _rules_keys, error=True, args=("rules", "{in}"),
         what="rules.json: one object of 4 million keys"),
    Case("error-escapes", _mcap_escape_only, error=True, note=("\\x1b]52",),
         absent=("\x1b", "\x07", "\x9b", "\x08"), cheap=True,
         what="MCAP with only escape-named String topics: the error names them"),
    Case("inspect-escapes", _mcap_escape_topic, args=("inspect", "{in}"),
         absent=("\x1b", "\x07", "\x9b", "\x08"), note=("\\x1b]52",),
         what="MCAP: topic names with OSC 52, CSI and other control characters (inspect)"),
    Case("ingest-escapes", _mcap_escape_topic, absent=("\x1b", "\x07", "\x9b", "\x08"),
         columns=RATES, note=("\\x1b]52",), cheap=True,
         rows=11900, what="the same MCAP through ingest: notes name the escape-named IMU copy"),
]
"""Every hostile structure, in the order of issue 23."""


def case(name: str) -> Case:
    """The case called ``name``."""
    return next(c for c in CASES if c.name == name)


# ---------------------------------------------------------------------------
# running


def _peak_rss_mb(pid: int) -> float:
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


def child_env(**extra: str) -> dict[str, str]:
    """The environment of an ``etsid`` child process: this checkout first on PYTHONPATH, so
    a fuzzer run from a git worktree tests that worktree's code, not the installed one."""
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PYTHONPATH": path, **extra}


def run_case(c: Case, work: Path, time_bound_s: float = TIME_BOUND_S,
             memory_bound_mb: float = MEMORY_BOUND_MB, kill_mb: float = 2048.0,
             env: dict[str, str] | None = None) -> Verdict:
    """Build ``c`` in ``work`` and run ``etsid`` on it in a child process.

    The child is killed past ``time_bound_s`` (a verdict of "timeout") or when its
    resident set passes ``kill_mb`` (verdict "memory"); the bounds checked are
    ``time_bound_s`` and ``memory_bound_mb``.
    """
    work.mkdir(parents=True, exist_ok=True)
    path = c.build(work)
    out = work / ("run" if "--out" in c.args else "table.parquet")
    args = [a.replace("{in}", str(path)).replace("{out}", str(out)) for a in c.args]
    start = time.perf_counter()
    time_bound_s = c.seconds or time_bound_s
    proc = subprocess.Popen([sys.executable, "-m", "etsid", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, cwd=work,
                            env=child_env(ETSID_PROGRESS="off", **(env or {})),
                            start_new_session=True)  # progress lines: as in the test suite
    peak, why = 0.0, ""
    while proc.poll() is None:
        peak = max(peak, _peak_rss_mb(proc.pid))
        if time.perf_counter() - start > time_bound_s:
            why = f"timeout (> {time_bound_s:.0f} s)"
        elif peak > kill_mb:
            why = f"memory (> {kill_mb:.0f} MB RSS)"
        if why:
            with contextlib.suppress(ProcessLookupError):  # its workers too (a pool)
                os.killpg(proc.pid, signal.SIGKILL)
            break
        time.sleep(0.05)
    with contextlib.suppress(ProcessLookupError, PermissionError):  # workers left behind
        os.killpg(proc.pid, signal.SIGKILL)  # (they would hold the output pipes open)
    stdout, stderr = proc.communicate()
    seconds = time.perf_counter() - start
    text = stdout.decode("utf-8", "replace") + stderr.decode("utf-8", "replace")
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if why:
        return Verdict(c.name, False, why, seconds, peak, lines)
    return _judge(c, proc.returncode, stdout, stderr, out, seconds, peak, path)


def _judge(c: Case, code: int, stdout: bytes, stderr: bytes, out: Path, seconds: float,
           peak: float, path: Path) -> Verdict:
    text = stdout.decode("utf-8", "replace") + "\n" + stderr.decode("utf-8", "replace")
    lines = [ln for ln in text.splitlines() if ln.strip()]
    err_lines = [ln for ln in stderr.decode("utf-8", "replace").splitlines() if ln.strip()]
    bounds = seconds <= (c.seconds or TIME_BOUND_S) and peak <= MEMORY_BOUND_MB
    raw = stdout + stderr
    for bad in c.absent:
        if bad.encode("utf-8") in raw or (len(bad) == 1 and ord(bad) < 128
                                          and bytes([ord(bad)]) in raw):
            return Verdict(c.name, False, f"raw {bad!r} printed", seconds, peak, lines)
    if "Traceback" in text or "internal error" in text:
        last = err_lines[-1] if err_lines else ""
        return Verdict(c.name, False, f"internal error: {last[:200]}", seconds, peak, lines)
    if c.error:
        if code == 1 and len(err_lines) == 1 and err_lines[0].startswith("etsid: error: ") \
                and len(err_lines[0]) <= 400:
            return Verdict(c.name, bounds, err_lines[0][:200], seconds, peak, lines)
        if code == 0:
            return Verdict(c.name, False, f"exit 0: {lines[-1][:200] if lines else ''}",
                           seconds, peak, lines)
        longest = max((len(ln) for ln in err_lines), default=0)
        return Verdict(c.name, False, f"exit {code}, {len(err_lines)} line(s) on stderr, the "
                       f"longest {longest} characters: {(err_lines or [''])[0][:150]}",
                       seconds, peak, lines)
    if code != 0:
        return Verdict(c.name, False, f"exit {code}: {(err_lines or [''])[-1][:200]}",
                       seconds, peak, lines)
    if c.columns:
        from etsid.table import load_table

        table = load_table(out)
        missing = [col for col in c.columns if col not in table.columns
                   or not table[col].notna().any()]
        if missing:
            return Verdict(c.name, False, f"table lacks {', '.join(missing)}", seconds, peak,
                           lines)
        if len(table) < c.rows:
            return Verdict(c.name, False, f"table has {len(table)} rows, the valid part "
                           f"gives at least {c.rows}", seconds, peak, lines)
    wrong = c.check(out, path, text) if c.check is not None else ""
    if wrong:
        return Verdict(c.name, False, wrong, seconds, peak, lines)
    absent_notes = [n for n in c.note if n not in text]
    if absent_notes:
        return Verdict(c.name, False, f"no note naming {absent_notes}", seconds, peak, lines)
    found = [ln for ln in lines if any(n in ln for n in c.note)]
    return Verdict(c.name, bounds, (found[0] if found else (lines[0] if lines else ""))[:200],
                   seconds, peak, lines)
