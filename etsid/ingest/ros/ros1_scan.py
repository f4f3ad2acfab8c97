"""ROS 1 bags read without their index: cut short, or with a damaged index or damaged chunks.

The file is walked record by record (every record: header length, header fields, data
length, data). A record that does not parse (zeroed or overwritten bytes) starts a resync:
the walk goes on at the next record whose ``op`` field is that of a chunk or connection
(top level) or a message or connection (inside a chunk) and whose header parses exactly.
The message just before a break inside a chunk is dropped too (its tail may be damaged).
A chunk that does not decompress keeps what its first bytes decompress to.

The bag header's ``index_pos`` says where the data end: bytes lost after it are only the
index. The notes give the messages kept and the seconds missing
(:func:`etsid.ingest.damage.gap_note`, :func:`~etsid.ingest.damage.cut_note`).
"""

from __future__ import annotations

import mmap
import struct
from pathlib import Path
from typing import Any

from etsid.errors import IngestError
from etsid.files import open_binary
from etsid.ingest import mapped
from etsid.ingest.base import RawLog, ReadOptions
from etsid.ingest.damage import cut_note, gap_note
from etsid.ingest.inflate import MAX_CHUNK_BYTES, inflate
from etsid.ingest.ros.converter import Converter

MAGIC = b"#ROSBAG V2.0\n"
_OP_MSG, _OP_HEADER, _OP_INDEX, _OP_CHUNK, _OP_CHUNK_INFO, _OP_CONN = 2, 3, 4, 5, 6, 7
_MAX_HEADER = 1 << 16


def _fields(buf: bytes | memoryview, op: bool = True) -> dict[str, bytes] | None:
    """Header fields, or None when they do not tile the header exactly (or, ``op``, lack
    the op field)."""
    out: dict[str, bytes] = {}
    pos = 0
    while pos + 4 <= len(buf):
        (size,) = struct.unpack_from("<I", buf, pos)
        if size == 0 or pos + 4 + size > len(buf):
            return None
        name, eq, value = bytes(buf[pos + 4:pos + 4 + size]).partition(b"=")
        if not eq or not name:
            return None
        out[name.decode("latin-1")] = value
        pos += 4 + size
    if pos != len(buf) or (op and len(out.get("op", b"")) != 1):
        return None
    return out


def _record_at(view: memoryview, pos: int) -> tuple[dict[str, bytes], memoryview, int] | None:
    """(header fields, data, end) of a complete, well-formed record at ``pos``."""
    if pos + 8 > len(view):
        return None
    (hlen,) = struct.unpack_from("<I", view, pos)
    if hlen > _MAX_HEADER or pos + 8 + hlen > len(view):
        return None
    header = _fields(view[pos + 4:pos + 4 + hlen])
    if header is None:
        return None
    (dlen,) = struct.unpack_from("<I", view, pos + 4 + hlen)
    end = pos + 8 + hlen + dlen
    if end > len(view):
        return None
    return header, view[pos + 8 + hlen:end], end


def _resync(view: memoryview, start: int, ops: tuple[int, ...]) -> int | None:
    """Start of the next well-formed record from ``start`` whose op is in ``ops``."""
    data = view.obj if isinstance(view.obj, (bytes, mmap.mmap)) else bytes(view)
    pos = start
    while True:
        i = mapped.find(data, b"\x04\x00\x00\x00op=", pos)
        if i < 0:
            return None
        if i + 7 < len(data) and data[i + 7] in ops:
            for h in range(i - 4, max(start, i - 260) - 1, -1):
                rec = _record_at(view, h)
                if rec is not None and rec[0].get("op", b"\0")[0] in ops:
                    return h
        pos = i + 1


def _decompress(kind: str, data: bytes | memoryview, declared: int | None) -> tuple[bytes, bool]:
    """As much of a (possibly cut or damaged) chunk as decompresses, bounded by its
    declared size (:func:`etsid.ingest.inflate.inflate`), and whether all of it did."""
    if kind not in ("none", "bz2", "lz4"):
        raise IngestError(f"unknown chunk compression {kind[:20]!r}")
    if declared is None:  # a header without its size: at most the limit
        declared = MAX_CHUNK_BYTES
        got = inflate(kind, data, declared)
        return got.data, got.error.startswith("chunk decompresses to ")
    got = inflate(kind, data, declared)
    return got.data, not got.error


class _Span:
    """Log times (ns) of the messages kept, and the gaps left by damage."""

    def __init__(self) -> None:
        self.first: int | None = None
        self.last: int | None = None
        self.messages = 0
        self.waiting = False
        self.gaps: list[tuple[int, int]] = []

    def take(self, log_ns: int) -> None:
        if self.waiting and self.last is not None:
            self.gaps.append((self.last, log_ns))
        self.waiting = False
        self.messages += 1
        self.first = log_ns if self.first is None else min(self.first, log_ns)
        self.last = log_ns if self.last is None else max(self.last, log_ns)

    def seconds(self, base: int | None, a: int | None, b: int | None
                ) -> tuple[float | None, float | None]:
        if base is None or a is None or b is None:
            return None, None
        return (a - base) * 1e-9, (b - base) * 1e-9


class _Scan:
    """Connections, converter and damage tally of one scan."""

    def __init__(self, options: ReadOptions) -> None:
        from rosbags.typesys import Stores, get_typestore

        self.conv = Converter(options)
        self.store = get_typestore(Stores.EMPTY)
        self.conns: dict[int, tuple[Any, str]] = {}
        self.span = _Span()
        self.bad: list[int] = []

    def connection(self, header: dict[str, bytes], body: memoryview) -> None:
        from rosbags.typesys import get_types_from_msg

        conn = header.get("conn", b"")
        if len(conn) != 4:
            return
        cid = struct.unpack("<I", conn)[0]
        if cid in self.conns:
            return
        info = _fields(body, op=False) or {}
        topic = header.get("topic", info.get("topic", b"")).decode("utf-8", "replace")
        msgtype = info.get("type", b"").decode("utf-8", "replace")
        pkg, _, name = msgtype.partition("/")
        typename = f"{pkg}/msg/{name}"
        try:
            self.store.register(get_types_from_msg(
                info.get("message_definition", b"").decode(), typename))
        except Exception:  # a bad definition only disables this topic
            self.conv.topic(topic, typename).spec = None
        self.conns[cid] = (self.conv.topic(topic, typename), typename)

    def message(self, header: dict[str, bytes], body: memoryview) -> bool:
        conn, stamp = header.get("conn", b""), header.get("time", b"")
        if len(conn) != 4 or len(stamp) != 8:
            return False
        cid = struct.unpack("<I", conn)[0]
        if cid not in self.conns:
            return False
        topic, typename = self.conns[cid]
        sec, nsec = struct.unpack("<II", stamp)
        log_ns = sec * 1_000_000_000 + nsec
        self.span.take(log_ns)
        if not topic.decode:
            self.conv.count(topic, log_ns)
            return True
        try:
            msg = self.store.deserialize_ros1(bytes(body), typename)
        except Exception as err:  # a damaged message: this one only, counted and noted
            self.conv.undecodable(topic, log_ns, err)
            return True
        self.conv.add(topic, msg, log_ns)
        return True

    def chunk(self, buf: bytes, pos: int, partial: bool) -> int:
        """Messages kept from one chunk's content (``partial``: the start of a cut one)."""
        view = memoryview(buf)
        at, kept = 0, 0
        pending: tuple[dict[str, bytes], memoryview] | None = None
        while at < len(view):
            rec = _record_at(view, at)
            if rec is None:
                resume = _resync(view, at + 1, (_OP_MSG, _OP_CONN))
                if resume is None and partial:
                    break
                pending = None  # the message before a break may be damaged
                self.bad.append(pos)
                self.span.waiting = True
                if resume is None:
                    return kept
                at = resume
                continue
            header, body, at = rec
            op = header["op"][:1]
            if op == bytes((_OP_CONN,)):
                self.connection(header, body)
            elif op == bytes((_OP_MSG,)):
                if pending is not None:
                    kept += self.message(*pending)
                pending = (header, body)
        if pending is not None:
            kept += self.message(*pending)
        return kept


def scan(path: Path, options: ReadOptions, raw: RawLog) -> Converter:
    """Read a ROS 1 bag without its index, keeping every complete message."""
    with open_binary(path, "log", IngestError) as handle:
        if handle.read(len(MAGIC)) != MAGIC:
            raise IngestError(f"{path}: not a ROS 1 bag (bad magic line)")
        with mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as data:
            view = memoryview(data)
            try:
                return _scan(path, view, options, raw)
            finally:
                view.release()


def _scan(path: Path, view: memoryview, options: ReadOptions, raw: RawLog) -> Converter:
    data = view
    state = _Scan(options)
    index_pos = None
    used = pos = len(MAGIC)
    tops = (_OP_CHUNK, _OP_CONN, _OP_HEADER, _OP_INDEX, _OP_CHUNK_INFO)
    while pos < len(data):
        rec = _record_at(view, pos)
        if rec is None:
            resume = _resync(view, pos + 1, (_OP_CHUNK, _OP_CONN))
            if resume is None:
                break
            state.bad.append(pos)
            state.span.waiting = True
            pos = resume
            continue
        header, body, end = rec
        op = header["op"][0]
        if op == _OP_CHUNK:
            kind = header.get("compression", b"none").decode("latin-1")
            inner, whole = _decompress(kind, body, _size(header))
            state.chunk(inner, pos, partial=not whole)
            if not whole:  # the rest of the chunk does not decompress
                state.bad.append(pos)
                state.span.waiting = True
        elif op == _OP_CONN:
            state.connection(header, body)
        elif op == _OP_HEADER and len(header.get("index_pos", b"")) == 8:
            index_pos = struct.unpack("<Q", header["index_pos"])[0]
        elif op not in tops:
            state.bad.append(pos)
        pos = used = end
    tail = len(data) - used
    cut_chunk = False
    if tail > 0 and (index_pos is None or index_pos == 0 or used < index_pos):
        # the last, cut record: keep the complete messages inside it
        part = _partial_chunk(view, used)
        if part is not None:
            cut_chunk = state.chunk(_decompress(*part)[0], used, partial=True) > 0
    _notes(path, raw, state, used, tail, index_pos, cut_chunk)
    raw.extra["storage"] = "rosbag1 (scanned without index)"
    return state.conv


def _notes(path: Path, raw: RawLog, state: _Scan, used: int, tail: int,
           index_pos: int | None, cut_chunk: bool) -> None:
    span, base = state.span, state.conv.base_ns
    first, last = span.seconds(base, span.first, span.last)
    bad = sorted(set(state.bad))
    if bad:
        where = ", ".join(str(b) for b in bad[:5]) + (" …" if len(bad) > 5 else "")
        gaps = [g for g in (span.seconds(base, a, b) for a, b in span.gaps)
                if g[0] is not None and g[1] is not None]
        raw.warnings.append(gap_note(path, f"skipped {len(bad)} damaged chunk(s) or record(s) at "
                                     f"byte {where}", gaps, first, last))  # type: ignore[arg-type]
    if tail <= 0:
        return
    if index_pos and used >= index_pos:
        raw.warnings.append(cut_note(path, f"index unreadable ({tail} byte(s) after the "
                                     f"data, from byte {used}); every chunk read",
                                     span.messages, first, last).replace(
                                         "; the rest of the recording is lost", ""))
        return
    raw.warnings.append(cut_note(
        path, f"truncated bag (no index): read the chunks before byte {used}"
        + (" and the complete messages of the cut chunk" if cut_chunk else "")
        + f"; {tail} byte(s) at the end could not be read", span.messages, first, last))


def _partial_chunk(view: memoryview, pos: int) -> tuple[str, memoryview, int | None] | None:
    if pos + 4 > len(view):
        return None
    (hlen,) = struct.unpack_from("<I", view, pos)
    if hlen > _MAX_HEADER or pos + 8 + hlen > len(view):
        return None
    header = _fields(view[pos + 4:pos + 4 + hlen])
    if header is None or header["op"][:1] != bytes((_OP_CHUNK,)):
        return None
    return (header.get("compression", b"none").decode("latin-1"), view[pos + 8 + hlen:],
            _size(header))


def _size(header: dict[str, bytes]) -> int | None:
    """The decompressed size a chunk header declares (None when it lacks one)."""
    value = header.get("size", b"")
    return struct.unpack("<I", value)[0] if len(value) == 4 else None
