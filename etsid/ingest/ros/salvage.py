"""The readable part of a damaged ROS 2 storage file (truncated or with broken pages).

rosbags refuses a ``.db3`` whose file is shorter than its header says ("database disk
image is malformed") or whose pages are broken, and an ``.mcap`` without its closing
magic. Here:

* ``.db3``: a copy padded with zero pages to the size the header promises opens again;
  the messages table is read in id order up to a broken page, and reading resumes at the
  first id after it that can be reached (ids probed at growing steps). Every skipped
  stretch is reported with its time span.
* ``.mcap``: read by etsid's MCAP reader, which keeps every chunk that decodes.
"""

from __future__ import annotations

import shutil
import sqlite3
import struct
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, fields
from pathlib import Path

from etsid.errors import IngestError
from etsid.files import open_binary
from etsid.ingest.base import RawLog, ReadOptions
from etsid.ingest.ros.converter import Converter

MAX_PROBE_STEP = 1 << 24
"""Largest id step tried when looking for the first readable row after a broken page."""


@dataclass
class LostRows:
    """Rows of the messages table that could not be read: ids and the times around them."""

    after_id: int
    before_id: int | None
    after_ns: int | None
    before_ns: int | None


def _padded_copy(storage: Path, tmp: Path) -> Path:
    """``storage`` copied into ``tmp``, padded with zeros to the size its header promises."""
    copy = tmp / storage.name
    with open_binary(storage, "log", IngestError) as source, copy.open("wb") as out:
        shutil.copyfileobj(source, out)
    with copy.open("r+b") as handle:  # etsid's own copy, read and padded in place
        head = handle.read(100)
        if len(head) < 100 or not head.startswith(b"SQLite format 3\0"):
            raise IngestError(f"{storage}: not an SQLite database (its header is damaged)")
        page = struct.unpack(">H", head[16:18])[0]
        page = 65536 if page == 1 else page
        pages = struct.unpack(">I", head[28:32])[0]
        size = copy.stat().st_size
        want = page * pages
        if size < want <= 64 * max(size, 1 << 20):  # a header claiming far more is damaged
            handle.seek(want - 1)
            handle.write(b"\0")
    return copy


def db3_rows(db: sqlite3.Connection, lost: list[LostRows]) -> Iterator[tuple[int, int, bytes]]:
    """(topic_id, timestamp ns, data) of every readable row, in id order; gaps go to
    ``lost``. Every round moves past at least one id, so a damaged tree cannot loop."""
    last_id, last_ns = 0, None
    while True:
        moved = False
        try:
            for row_id, tid, stamp, data in db.execute(
                    "SELECT id, topic_id, timestamp, data FROM messages WHERE id > ? "
                    "ORDER BY id", (last_id,)):
                if row_id <= last_id:  # a damaged tree that runs backwards
                    raise sqlite3.DatabaseError("row ids out of order")
                last_id, last_ns, moved = row_id, stamp, True
                yield tid, stamp, data
            return
        except sqlite3.Error:
            pass
        step, resumed = (1 if moved or not lost else 2), None
        while step <= MAX_PROBE_STEP:
            try:
                row = db.execute("SELECT id, timestamp FROM messages WHERE id > ? ORDER BY id "
                                 "LIMIT 1", (last_id + step,)).fetchone()
            except sqlite3.Error:
                step *= 2
                continue
            resumed = row
            break
        if resumed is None or resumed[0] <= last_id:
            lost.append(LostRows(last_id, None, last_ns, None))
            return
        lost.append(LostRows(last_id, resumed[0], last_ns, resumed[1]))
        last_id = resumed[0] - 1 if moved or step == 1 else resumed[0]


def read_db3(storage: Path, options: ReadOptions, raw: RawLog) -> Converter:
    """Convert the readable rows of a damaged ``.db3`` into a fresh Converter.

    A message that does not deserialise is skipped alone (damaged bytes hit single rows);
    the counts are noted per topic.
    """
    from etsid.ingest.damage import decoder_errors
    from etsid.rosmsgs import typestore

    conv = Converter(options)
    store = typestore(ros1=False)
    errors = decoder_errors()
    lost: list[LostRows] = []
    last_ns: int | None = None
    with tempfile.TemporaryDirectory() as tmp:
        copy = _padded_copy(storage, Path(tmp))
        db = sqlite3.connect(f"{copy.resolve().as_uri()}?immutable=1", uri=True)
        try:
            try:
                topics = {tid: conv.topic(str(name or ""), str(msgtype or ""))  # NULLs
                          for tid, name, msgtype in
                          db.execute("SELECT id, name, type FROM topics").fetchall()}
            except sqlite3.Error as err:
                raise IngestError(f"{storage}: damaged ROS 2 storage, its topic list is "
                                  f"unreadable ({err})") from err
            for tid, stamp, data in db3_rows(db, lost):
                topic = topics.get(tid)
                if topic is None:
                    continue
                if isinstance(stamp, int) and (last_ns is None or stamp > last_ns):
                    last_ns = stamp
                if not topic.decode or data is None:
                    conv.count(topic, stamp)
                    continue
                try:
                    msg = store.deserialize_cdr(bytes(data), topic.msgtype)
                except errors as err:  # this message only: counted, noted with its times
                    conv.undecodable(topic, stamp, err)
                    continue
                conv.add(topic, msg, stamp)
        finally:
            db.close()
    kept = sum(t.count for t in conv.topics.values())
    if not kept:
        raise IngestError(f"{storage}: damaged ROS 2 storage, no message could be read")
    if lost:
        raw.warnings.append(_lost_note(storage, lost, conv.base_ns, kept, last_ns))
    raw.extra["storage"] = "sqlite3 (salvaged)"
    raw.extra["message_count"] = kept
    return conv


def _lost_note(storage: Path, lost: list[LostRows], base_ns: int | None, kept: int,
               last_ns: int | None = None) -> str:
    """One line: how many stretches of rows were lost, and which seconds of the recording
    (:func:`etsid.ingest.damage.gap_note`)."""
    from etsid.ingest.damage import gap_note

    spans = []
    for gap in lost:
        if base_ns is None or gap.after_ns is None or gap.before_ns is None:
            continue
        spans.append(((gap.after_ns - base_ns) * 1e-9, (gap.before_ns - base_ns) * 1e-9))
    last = None if base_ns is None or last_ns is None else (last_ns - base_ns) * 1e-9
    what = (f"damaged storage: {len(lost)} stretch(es) of messages unreadable, "
            f"kept {kept} message(s)")
    if lost[-1].before_id is None:
        tail = lost[-1].after_ns
        what += "; everything after " + (f"t = {(tail - base_ns) * 1e-9:.1f} s"
                                         if tail is not None and base_ns is not None
                                         else "the damage") + " is lost"
    return gap_note(storage, what, spans, 0.0 if last is not None else None, last)


def read_mcap(storage: Path, options: ReadOptions, raw: RawLog,
              total_s: float | None = None) -> None:
    """Fill ``raw`` from a damaged ``.mcap`` storage file read by etsid's MCAP reader
    (``total_s``: the recording's length per metadata.yaml)."""
    from etsid.ingest.ros import mcap

    sub = mcap.read(storage, options, total_s)
    for item in fields(RawLog):
        if item.name not in ("path", "format", "warnings"):
            setattr(raw, item.name, getattr(sub, item.name))
    raw.warnings.extend(sub.warnings)
    raw.extra["storage"] = "mcap (salvaged)"
    raw.extra["message_count"] = sum(c.count for c in raw.channels)
