"""Damaged or cut MCAP files: every record that decodes, before and after the damage.

:func:`scan` walks a file that the strict walker of :mod:`.mcap` refuses (closing magic
missing, a top-level record broken). MCAP records are self-delimiting (opcode, 64-bit
length), so the walk goes on after damage by finding where records start again:

* top level: the chunk offsets of the summary's chunk indexes when the summary survived,
  else the next byte that starts a plausible chunk (opcode 6, a length that fits, a header
  whose times, sizes and compression name agree) or a plausible message record;
* inside a chunk (:func:`chunk_records`): a chunk that does not decompress is decompressed
  as far as its bytes allow; a compressed chunk that decompresses but fails its CRC is
  skipped whole (garbled from an unknown point on); a chunk whose records break (zeroed
  or overwritten bytes) is walked record by record (every message's log time must lie in
  the chunk's time range) and resumes at the next message record whose channel is known,
  whose log time lies in the chunk's time range and which is followed by another valid
  record. The record just before a break is dropped too (its tail may be damaged).

Every skipped stretch is yielded as a :class:`Lost` (byte position, bytes, why) at the
point of the stream where it happened, so the reader can time it from the messages around
it; a file cut short ends with a :class:`Cut`.
"""

from __future__ import annotations

import mmap
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from etsid.errors import IngestError
from etsid.files import open_binary
from etsid.ingest import mapped
from etsid.ingest.inflate import (
    MAX_CHUNK_BYTES,
    MAX_RECORD_BYTES,
    Inflated,
    inflate,
    too_large,
)
from etsid.ingest.ros.fast import mcap as strict

_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 1, 2, 3, 4, 5, 6
_OP_CHUNK_INDEX = 8
_KNOWN_OPS = frozenset(range(1, 16))
_RECORD = struct.Struct("<BQ")
_COMPRESSIONS = ("", "zstd", "lz4")


@dataclass
class Lost:
    """A stretch of the file that was skipped: where, how many bytes, why, and the log
    times of the chunk it belonged to (ns; None when unknown)."""

    pos: int
    nbytes: int
    why: str
    start_ns: int | None = None
    end_ns: int | None = None


@dataclass
class Cut:
    """The file ends inside a record: readable bytes end at ``pos`` of ``size``."""

    pos: int
    size: int


# ---------------------------------------------------------------------------
# inside a chunk


def _fits(buf: bytes, pos: int, end: int) -> tuple[int, int] | None:
    """(opcode, next position) of a record at ``pos`` that fits in ``buf[:end]``."""
    if pos + 9 > end:
        return None
    op, length = _RECORD.unpack_from(buf, pos)
    nxt = pos + 9 + length
    if op not in _KNOWN_OPS or nxt > end or (op == _OP_MESSAGE and length < 22):
        return None
    return op, nxt


def _parses(buf: bytes, pos: int, op: int) -> Any:
    """The Schema/Channel/Header object at ``pos`` (record start), or None if broken."""
    try:
        if op == _OP_SCHEMA:
            return strict._schema(buf, pos + 9)
        if op == _OP_CHANNEL:
            return strict._channel(buf, pos + 9)
        if op == _OP_HEADER:
            return strict._header(buf, pos + 9)
    except (struct.error, UnicodeDecodeError, ValueError, IndexError):
        return None
    return True


class _Context:
    """What the walk knows: channel ids seen so far and the chunk's time range."""

    def __init__(self) -> None:
        self.channels: set[int] = set()
        self.lo_ns: int | None = None
        self.hi_ns: int | None = None

    def plausible_message(self, buf: bytes, pos: int) -> bool:
        cid, _, log_ns = struct.unpack_from("<HIQ", buf, pos + 9)
        if self.channels and cid not in self.channels:
            return False
        if self.lo_ns is not None and self.hi_ns is not None:
            return self.lo_ns <= log_ns <= self.hi_ns
        return True


def _resync_inner(buf: bytes, start: int, end: int, ctx: _Context) -> int | None:
    """First position from ``start`` where a plausible message record begins and the
    record after it is valid too (or the buffer ends exactly there)."""
    pos = start
    while True:
        pos = buf.find(b"\x05", pos, end - 30)
        if pos < 0:
            return None
        got = _fits(buf, pos, end)
        if got is not None and ctx.plausible_message(buf, pos):
            nxt = got[1]
            if nxt == end or _fits(buf, nxt, end) is not None:
                return pos
        pos += 1


def walk(buf: bytes, ctx: _Context, partial: bool) -> Iterator[Any]:
    """Records of a chunk's content: Schema/Channel/Header objects, :class:`strict.Messages`
    runs and :class:`Lost` stretches. ``partial``: ``buf`` is the decompressed start of a
    cut chunk, so a record running past its end is where the readable part ends."""
    pos, end = 0, len(buf)
    run: list[int] = []
    while pos < end:
        got = _fits(buf, pos, end)
        obj = None
        if got is not None and got[0] != _OP_MESSAGE:
            obj = _parses(buf, pos, got[0])
        if got is not None and got[0] == _OP_MESSAGE and not ctx.plausible_message(buf, pos):
            got = None  # a log time outside the chunk's range: damaged bytes
        if got is not None and (got[0] == _OP_MESSAGE or obj is not None):
            op, nxt = got
            if op == _OP_MESSAGE:
                run.append(pos)
            else:
                if run:
                    yield strict._messages(buf, run)
                    run = []
                if op == _OP_CHANNEL:
                    ctx.channels.add(obj.id)
                if op in (_OP_SCHEMA, _OP_CHANNEL, _OP_HEADER):
                    yield obj
            pos = nxt
            continue
        resume = _resync_inner(buf, pos + 1, end, ctx)
        if resume is None and partial:
            break  # the cut: the caller reports it
        back = run.pop() if run else pos  # the record before a break may be damaged
        if run:
            yield strict._messages(buf, run)
            run = []
        stop = end if resume is None else resume
        yield Lost(back, stop - back, "broken records inside a chunk")
        if resume is None:
            return
        pos = resume
    if run:
        yield strict._messages(buf, run)


def chunk_records(buf: bytes, pos: int, end: int, ctx: _Context,
                  tried: Inflated | None = None) -> Iterator[Any]:
    """Records of the chunk whose record starts at ``pos`` (opcode byte), its bytes ending
    at ``end`` (the declared end, or where the file or the damage cuts it). ``tried``:
    what the strict reader's decompression of this chunk gave (each chunk is decompressed
    once, bounded by :func:`etsid.ingest.inflate.inflate`)."""
    body = pos + 9
    try:
        start_ns, end_ns, size, _ = struct.unpack_from("<QQQI", buf, body)
        kind, at = strict._string(buf, body + 28)
        (n,) = struct.unpack_from("<Q", buf, at)
    except (struct.error, UnicodeDecodeError):
        yield Lost(pos, end - pos, "chunk header unreadable")
        return
    ctx.lo_ns, ctx.hi_ns = (start_ns, end_ns) if start_ns <= end_ns else (None, None)
    if kind not in _COMPRESSIONS:
        yield Lost(pos, end - pos, f"unknown chunk compression {kind[:20]!r}", start_ns, end_ns)
        return
    if too_large(size):
        yield Lost(pos, end - pos, too_large(size), start_ns, end_ns)
        return
    complete = at + 8 + n <= end
    if tried is None and complete:
        try:
            tried = Inflated(strict._chunk(buf, body, end - body))
        except strict._Damaged as err:
            tried = err.inflated
    if tried is None:  # cut chunk (or a corrupt length): its readable start
        tried = inflate(kind, buf[at + 8:min(at + 8 + n, end)], size)
        tried.error = tried.error or "chunk cut short"
    why = tried.error if complete else "chunk cut short"
    if not why:
        yield from list(walk(tried.data, ctx, partial=False))
        return
    garbled = "CRC" in why or "decompresses to" in why
    if kind and garbled:
        # a compressed stream that decompresses to the wrong bytes is garbled from the
        # damage onwards, and where that starts is not known: the chunk is skipped whole
        yield Lost(pos, end - pos, why, start_ns, end_ns)
        return
    if garbled:
        # stored, but the bytes are not what was written: keep records only where
        # the damage shows (a break in the record structure); an intact-looking chunk with
        # a bad checksum cannot be located and is skipped whole
        found = list(walk(tried.data, ctx, partial=False))
        if not any(isinstance(r, Lost) for r in found):
            yield Lost(pos, end - pos, why, start_ns, end_ns)
            return
        yield from found
        return
    yield from list(walk(tried.data, ctx, partial=True))
    if complete:
        yield Lost(pos, end - pos, f"{why}; kept the records that decompressed",
                   start_ns, end_ns)


# ---------------------------------------------------------------------------
# top level


def _plausible_chunk(buf: Any, pos: int, size: int, cut: bool = False) -> int | None:
    """End of a plausible chunk record at ``pos``, else None. ``cut``: the chunk may run
    past the end of the file (which then ends inside it)."""
    try:
        op, length = _RECORD.unpack_from(buf, pos)
        if op != _OP_CHUNK or (pos + 9 + length > size and not cut) or length < 40:
            return None
        start_ns, end_ns, usize, _ = struct.unpack_from("<QQQI", buf, pos + 9)
        (klen,) = struct.unpack_from("<I", buf, pos + 37)
        if start_ns > end_ns or usize > MAX_CHUNK_BYTES or klen > 4 \
                or length > MAX_RECORD_BYTES:
            return None
        if bytes(buf[pos + 41:pos + 41 + klen]).decode("ascii") not in _COMPRESSIONS:
            return None
        (n,) = struct.unpack_from("<Q", buf, pos + 41 + klen)
    except (struct.error, UnicodeDecodeError):
        return None
    end = pos + 9 + length
    return end if pos + 49 + klen + n == end else None


def _index_offsets(buf: Any, size: int) -> list[int]:
    """Chunk offsets from the summary's chunk indexes, when footer and summary survived."""
    try:
        if bytes(buf[size - 8:size]) != strict.MAGIC:
            return []
        footer = size - 8 - 29
        op, length = _RECORD.unpack_from(buf, footer)
        if op != _OP_FOOTER or length != 20:
            return []
        (summary,) = struct.unpack_from("<Q", buf, footer + 9)
        if not 8 <= summary < footer:
            return []
        out, pos = [], summary
        while pos + 9 <= footer:
            op, length = _RECORD.unpack_from(buf, pos)
            if op == _OP_CHUNK_INDEX and length >= 32:
                out.append(struct.unpack_from("<Q", buf, pos + 9 + 16)[0])
            pos += 9 + length
        return sorted(o for o in out if 8 <= o < summary)
    except struct.error:
        return []


def _resync_top(buf: Any, start: int, size: int, index: list[int], ctx: _Context) -> int | None:
    """Where top-level records start again after damage at ``start - 1``."""
    for off in index:
        if off >= start and _plausible_chunk(buf, off, size) is not None:
            found = off
            break
    else:
        found = None
    limit = size if found is None else found
    pos = start
    chunk = message = start - 1  # next candidate of each kind (found lazily, once each)
    while pos < limit:
        if chunk != -1 and chunk < pos:
            chunk = mapped.find(buf, b"\x06", pos, limit)
        if message != -1 and message < pos:
            message = mapped.find(buf, b"\x05", pos, limit) if ctx.channels else -1
        cands = [c for c in (chunk, message) if c >= 0]
        if not cands:
            break
        pos = min(cands)
        if pos == chunk and _plausible_chunk(buf, pos, size) is not None:
            return pos
        if pos == message and pos + 31 <= size:
            got = _fits(buf, pos, size)
            if got is not None and ctx.plausible_message(buf, pos):
                nxt = got[1]
                if nxt == size or _fits(buf, nxt, size) is not None:
                    return pos
        pos += 1
    return found


def scan(path: Path) -> Iterator[Any]:
    """Records of a damaged or cut MCAP file: Header/Schema/Channel objects,
    :class:`strict.Messages` runs, :class:`Lost` stretches and a final :class:`Cut`."""
    size = Path(path).stat().st_size
    if size == 0:
        return
    with open_binary(path, "log", IngestError) as handle, \
            mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as buf:
        yield from _scan(buf, size)


def _scan(buf: Any, size: int) -> Iterator[Any]:
    ctx = _Context()
    index = _index_offsets(buf, size)
    pos = len(strict.MAGIC) if bytes(buf[:8]) == strict.MAGIC else 0
    run = bytearray()

    def flush() -> Iterator[Any]:
        nonlocal run
        if run:
            data = bytes(run)
            run = bytearray()
            yield from walk(data, ctx, partial=False)

    while pos < size:
        if size - pos < 9:
            yield from flush()
            if bytes(buf[pos:size]) != strict.MAGIC[:size - pos]:
                yield Cut(pos, size)
            return
        op, length = _RECORD.unpack_from(buf, pos)
        nxt = pos + 9 + length
        if op in _KNOWN_OPS and nxt <= size:
            if op == _OP_MESSAGE and 22 <= length <= MAX_RECORD_BYTES:
                run += buf[pos:nxt]
                if len(run) > strict.RUN_BYTES:
                    yield from flush()
                pos = nxt
                continue
            yield from flush()
            if op == _OP_CHUNK and _plausible_chunk(buf, pos, size) is not None:
                yield from _chunk_at(buf, pos, nxt, ctx)
                pos = nxt
                continue
            if op in (_OP_SCHEMA, _OP_CHANNEL, _OP_HEADER) and length <= MAX_RECORD_BYTES:
                rec = bytes(buf[pos:nxt])
                obj = _parses(rec, 0, op)
                if obj is not None:
                    if op == _OP_CHANNEL:
                        ctx.channels.add(obj.id)
                    yield obj
                    pos = nxt
                    continue
            elif op == _OP_FOOTER:
                return
            elif op not in (_OP_CHUNK, _OP_MESSAGE):
                pos = nxt  # summary, index, attachment … records: not needed
                continue
        yield from flush()
        if op == _OP_CHUNK and nxt > size and _plausible_chunk(buf, pos, size, cut=True):
            yield from _chunk_at(buf, pos, size, ctx, cut=True)  # the file ends inside it
            yield Cut(pos, size)
            return
        resume = _resync_top(buf, pos + 1, size, index, ctx)
        if resume is None:
            if op in _KNOWN_OPS and nxt > size:  # the file ends inside this record
                yield Cut(pos, size)
            else:
                yield Lost(pos, size - pos, "damaged records up to the end of the file")
            return
        if op == _OP_CHUNK:  # keep what the damaged chunk still holds
            yield from _chunk_at(buf, pos, resume, ctx, cut=True)
            yield Lost(pos, resume - pos, "damaged chunk")
        else:
            yield Lost(pos, resume - pos, "damaged records")
        pos = resume
    yield from flush()


def _chunk_at(buf: Any, pos: int, end: int, ctx: _Context, cut: bool = False) -> Iterator[Any]:
    """The records of the chunk at file position ``pos`` (its bytes up to ``end``)."""
    data = bytes(buf[pos:end])
    for rec in chunk_records(data, 0, len(data), ctx):
        if isinstance(rec, Lost):
            if cut:
                continue  # the caller reports the damaged stretch as one
            rec.pos += pos
        yield rec
