"""Complete MCAP files read with numpy: no Python object per message.

:class:`mcap.stream_reader.StreamReader` builds a record object per message through
several small reads (≈ 60 k msg/s). This module walks the records itself: top-level
records and the records of each decompressed chunk (none/zstd/lz4) are located with one
``struct.unpack_from`` each, and the message records of a run (the messages between two
Schema/Channel records) are read at once with numpy gathers: channel id, log time, body
offset and length. Same-length bodies of one channel come out as a (messages, bytes)
array for :func:`etsid.ingest.ros.fast.decode.decode_batch`.

Only complete files (closing magic present) are read here; a cut file, or damage outside
the chunks, raises :class:`NotFast` and the caller uses the stream reader, which reports
the damage. A chunk that does not decompress, fails its CRC or holds broken records is
handed to :func:`.mcap_resync.chunk_records`, which keeps the records that still decode
and reports the rest as a :class:`~.mcap_resync.Lost` (the chunks after it are still read).
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from etsid.errors import IngestError
from etsid.files import open_binary
from etsid.ingest.inflate import MAX_RECORD_BYTES, Inflated, inflate, too_large

MAGIC = b"\x89MCAP0\r\n"
_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 1, 2, 3, 4, 5, 6
_RECORD = struct.Struct("<BQ")


class NotFast(Exception):
    """The file needs the stream reader (cut short, damaged, unknown compression)."""


class _Damaged(Exception):
    """A chunk's bytes are broken (bad compression, CRC, length or inner record);
    ``inflated``: what its one decompression gave (None when it was not decompressed)."""

    def __init__(self, why: str, inflated: Inflated | None = None) -> None:
        super().__init__(why)
        self.inflated = inflated


@dataclass
class Messages:
    """A run of message records inside one buffer.

    Attributes
    ----------
    buf : numpy.ndarray
        uint8 view of the buffer holding the records.
    channel : numpy.ndarray
        Channel id per message.
    log_ns : numpy.ndarray
        int64 log time per message, ns.
    start, size : numpy.ndarray
        int64 offset and length of each message body in ``buf``.
    """

    buf: np.ndarray
    channel: np.ndarray
    log_ns: np.ndarray
    start: np.ndarray
    size: np.ndarray

    def bodies(self, mask: np.ndarray) -> tuple[np.ndarray | None, list[bytes]]:
        """Bodies of the messages in ``mask``: one uint8 (messages, bytes) array when they
        have the same length, else a list of bytes."""
        start, size = self.start[mask], self.size[mask]
        if len(size) and (size == size[0]).all():
            return self.buf[start[:, None] + np.arange(int(size[0]))], []
        raw = self.buf.tobytes() if len(start) else b""
        return None, [raw[s:s + n] for s, n in zip(start.tolist(), size.tolist(), strict=True)]


def _string(buf: bytes, pos: int) -> tuple[str, int]:
    (n,) = struct.unpack_from("<I", buf, pos)
    return bytes(buf[pos + 4:pos + 4 + n]).decode(), pos + 4 + n


def _schema(buf: bytes, pos: int) -> Any:
    from mcap.records import Schema

    (sid,) = struct.unpack_from("<H", buf, pos)
    name, pos = _string(buf, pos + 2)
    encoding, pos = _string(buf, pos)
    (n,) = struct.unpack_from("<I", buf, pos)
    return Schema(id=sid, name=name, encoding=encoding, data=bytes(buf[pos + 4:pos + 4 + n]))


def _channel(buf: bytes, pos: int) -> Any:
    from mcap.records import Channel

    cid, sid = struct.unpack_from("<HH", buf, pos)
    topic, pos = _string(buf, pos + 4)
    encoding, pos = _string(buf, pos)
    (n,) = struct.unpack_from("<I", buf, pos)
    meta: dict[str, str] = {}
    end, pos = pos + 4 + n, pos + 4
    while pos < end:
        key, pos = _string(buf, pos)
        meta[key], pos = _string(buf, pos)
    return Channel(id=cid, schema_id=sid, topic=topic, message_encoding=encoding,
                   metadata=meta)


def _header(buf: bytes, pos: int) -> Any:
    from mcap.records import Header

    profile, pos = _string(buf, pos)
    library, _ = _string(buf, pos)
    return Header(profile=profile, library=library)


def _messages(buf: bytes, positions: list[int]) -> Messages:
    u8 = np.frombuffer(buf, dtype=np.uint8)
    pos = np.asarray(positions, dtype=np.int64)
    length = u8[pos[:, None] + np.arange(1, 9)].view("<u8").ravel().astype(np.int64)
    channel = u8[pos[:, None] + np.arange(9, 11)].view("<u2").ravel()
    log_ns = u8[pos[:, None] + np.arange(15, 23)].view("<u8").ravel().astype(np.int64)
    return Messages(u8, channel, log_ns, pos + 31, length - 22)


def _walk(buf: bytes, start: int, end: int, top: bool) -> Iterator[Any]:
    """Records of ``buf[start:end]``: Header/Schema/Channel objects, :class:`Messages` runs,
    chunk contents (recursively); stops after the footer."""
    pos = start
    run: list[int] = []
    unpack = _RECORD.unpack_from
    while pos < end:
        if pos + 9 > end:
            raise NotFast("record cut short")
        op, length = unpack(buf, pos)
        nxt = pos + 9 + length
        if nxt > end:
            raise NotFast("record cut short")
        if op == _OP_MESSAGE:
            if length < 22:
                raise NotFast("short message record")
            run.append(pos)
        elif op == 0:  # no record has opcode 0: zeroed bytes (walked by the resync)
            raise NotFast("opcode 0")
        elif op in (_OP_SCHEMA, _OP_CHANNEL, _OP_HEADER, _OP_CHUNK, _OP_FOOTER):
            if run:
                yield _messages(buf, run)
                run = []
            if op == _OP_SCHEMA:
                yield _schema(buf, pos + 9)
            elif op == _OP_CHANNEL:
                yield _channel(buf, pos + 9)
            elif op == _OP_HEADER:
                yield _header(buf, pos + 9)
            elif op == _OP_CHUNK and top:
                yield from _chunk_records(buf, pos + 9, length)
            elif op == _OP_FOOTER:
                return
        pos = nxt
    if run:
        yield _messages(buf, run)


def _chunk_records(buf: bytes, pos: int, length: int) -> Iterator[Any]:
    """The records of the chunk at ``pos``; a damaged chunk goes to the resync walker,
    which keeps what still decodes (from the one decompression already made) and yields a
    :class:`~.mcap_resync.Lost` for the rest."""
    tried: Inflated | None = None
    try:
        inner = _chunk(buf, pos, length)
        tried = Inflated(inner)
        found = list(_walk(inner, 0, len(inner), False))
    except _Damaged as err:
        tried = err.inflated
    except NotFast as err:
        if str(err).startswith("compression"):
            raise
    except (struct.error, UnicodeDecodeError, ValueError, IndexError, MemoryError):
        pass
    else:
        yield from found
        return
    from etsid.ingest.ros.fast import mcap_resync

    data = bytes(buf[pos - 9:pos + length])
    for rec in mcap_resync.chunk_records(data, 0, len(data), mcap_resync._Context(), tried):
        if isinstance(rec, mcap_resync.Lost):
            rec.pos += pos - 9
        yield rec


def _chunk(buf: bytes, pos: int, length: int) -> bytes:
    """The decompressed records of the chunk whose body starts at ``pos``.

    Raises
    ------
    _Damaged
        Lengths, decompression (bounded: :func:`etsid.ingest.inflate.inflate`) or CRC
        wrong; it carries what decompressed.
    NotFast
        An unknown compression.
    """
    import zlib

    size, crc = struct.unpack_from("<QI", buf, pos + 16)
    kind, at = _string(buf, pos + 28)
    (n,) = struct.unpack_from("<Q", buf, at)
    if at + 8 + n > pos + length:
        raise _Damaged("corrupt chunk length")
    if kind not in ("", "zstd", "lz4"):
        raise NotFast(f"compression {kind!r}")
    if too_large(size):
        raise _Damaged(too_large(size), Inflated(b"", too_large(size)))
    got = inflate(kind, buf[at + 8:at + 8 + n], size)
    if got.error:
        raise _Damaged(got.error, got)
    if crc and zlib.crc32(got.data) != crc:
        raise _Damaged("chunk CRC mismatch", Inflated(got.data, "chunk CRC mismatch"))
    return got.data


def _top(handle: Any, end: int) -> Iterator[Any]:
    """Top-level records read one at a time (memory: one chunk); unchunked message records
    are gathered into runs of up to ``RUN_BYTES``."""
    run = bytearray()
    while handle.tell() < end:
        head = handle.read(9)
        if len(head) < 9:
            raise NotFast("record cut short")
        op, length = _RECORD.unpack(head)
        if handle.tell() + length > end:
            raise NotFast("record cut short")
        if length > MAX_RECORD_BYTES and op in (_OP_MESSAGE, _OP_CHUNK, _OP_SCHEMA,
                                                _OP_CHANNEL, _OP_HEADER, _OP_FOOTER):
            raise NotFast("record longer than any chunk read")  # the resync skips it
        if op == _OP_MESSAGE:
            run += head
            run += handle.read(length)
            if len(run) > RUN_BYTES:
                yield from _walk(bytes(run), 0, len(run), False)
                run = bytearray()
            continue
        if op not in (_OP_SCHEMA, _OP_CHANNEL, _OP_HEADER, _OP_CHUNK, _OP_FOOTER):
            handle.seek(length, 1)
            continue
        if run:
            yield from _walk(bytes(run), 0, len(run), False)
            run = bytearray()
        base = handle.tell() - 9
        body = head + handle.read(length)
        for rec in _walk(body, 0, len(body), True):
            if hasattr(rec, "nbytes"):  # a Lost stretch: file position
                rec.pos += base
            yield rec
        if op == _OP_FOOTER:
            return
    if run:
        yield from _walk(bytes(run), 0, len(run), False)


RUN_BYTES = 4 << 20
"""Bytes of message records gathered before a run is decoded."""


def summary_channels(path: Path) -> tuple[dict[int, Any], dict[int, Any]]:
    """Schemas and channels repeated in the summary section of ``path`` (by id), read
    without decompressing anything: what defines the messages whose Schema/Channel records
    were in a chunk that is lost. Empty when the file has no summary or it is damaged.
    """
    from mcap.records import Channel, Schema

    schemas: dict[int, Any] = {}
    channels: dict[int, Any] = {}
    size = Path(path).stat().st_size
    tail = len(MAGIC) + 9 + 20
    if size < len(MAGIC) + tail:
        return schemas, channels
    with open_binary(path, "log", IngestError) as handle:
        handle.seek(size - tail)
        footer = handle.read(tail)
        if footer[-len(MAGIC):] != MAGIC or footer[0] != _OP_FOOTER:
            return schemas, channels
        (start,) = struct.unpack_from("<Q", footer, 9)
        end = size - tail
        if not len(MAGIC) < start < end or end - start > MAX_RECORD_BYTES:
            return schemas, channels
        handle.seek(start)
        buf = handle.read(end - start)
    try:
        for rec in _walk(buf, 0, len(buf), False):
            if isinstance(rec, Schema):
                schemas[rec.id] = rec
            elif isinstance(rec, Channel):
                channels[rec.id] = rec
    except (NotFast, struct.error, UnicodeDecodeError, ValueError, IndexError):
        return {}, {}
    return schemas, channels


def records(path: Path) -> Iterator[Any]:
    """Header/Schema/Channel records and :class:`Messages` runs of a complete MCAP file.

    Raises
    ------
    NotFast
        Not a complete MCAP file (the caller falls back to the stream reader).
    """
    size = Path(path).stat().st_size
    with open_binary(path, "log", IngestError) as handle:
        if size < 2 * len(MAGIC) + 9 or handle.read(len(MAGIC)) != MAGIC:
            raise NotFast("not an MCAP file")
        handle.seek(size - len(MAGIC))
        if handle.read(len(MAGIC)) != MAGIC:
            raise NotFast("not a complete MCAP file")
        handle.seek(len(MAGIC))
        try:
            yield from _top(handle, size - len(MAGIC))
        except (struct.error, UnicodeDecodeError, ValueError, IndexError) as err:
            raise NotFast(str(err)) from err
