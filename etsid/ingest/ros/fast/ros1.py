"""Indexed ROS 1 bags read with numpy: chunk by chunk, messages gathered per connection.

rosbags' ROS 1 reader builds one Python object per index entry, sorts them with a
Python-level comparison and seeks through a BytesIO for every message (≈ 30 k msg/s,
slower per message as bags grow). This reader reads the same records directly:

* the bag header, then at ``index_pos`` the connection and chunk-info records;
* each chunk once, in file order: decompressed (none/lz4/bz2, bounded by its declared
  size: :func:`etsid.ingest.inflate.inflate`), then its index-data records
  (per connection: time sec, nsec and offset of each message, as a numpy array) give the
  message records, whose headers, lengths and bodies are gathered with numpy fancy
  indexing; same-length messages come out as one (messages, bytes) array.

It yields, per chunk and connection, the messages in index order. It only accepts bags
where that order is the one rosbags gives (record times non-decreasing per topic across
chunks, one connection per topic, every message record header alike); otherwise
:class:`NotFast` is raised before anything is converted, and the caller uses rosbags.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

from etsid.errors import IngestError
from etsid.files import open_handle
from etsid.ingest.inflate import MAX_RECORD_BYTES, inflate

_MAGIC = b"#ROSBAG V2.0\n"
_OP_MSG, _OP_HEADER, _OP_INDEX, _OP_CHUNK, _OP_CHUNK_INFO, _OP_CONN = 2, 3, 4, 5, 6, 7
_INDEX = np.dtype([("sec", "<u4"), ("nsec", "<u4"), ("offset", "<u4")])


class NotFast(Exception):
    """The bag needs rosbags' general reader (no index, odd layout, unknown compression)."""


@dataclass
class Connection:
    """One ROS 1 connection (topic, type, embedded definition)."""

    id: int
    topic: str
    msgtype: str
    definition: str
    count: int = 0


@dataclass
class _Chunk:
    pos: int
    counts: dict[int, int]
    start_ns: int = 0
    end_ns: int = 0


class Damaged(NotFast):
    """A chunk's bytes are broken (bad compression, length, offset or record)."""


@dataclass
class LostChunk:
    """A chunk skipped because it is damaged: where, how many messages, which times, why."""

    pos: int
    messages: int
    start_ns: int
    end_ns: int
    why: str


def _fields(buf: bytes) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    pos = 0
    while pos + 4 <= len(buf):
        (size,) = struct.unpack_from("<I", buf, pos)
        name, _, value = buf[pos + 4:pos + 4 + size].partition(b"=")
        out[name.decode("latin-1")] = value
        pos += 4 + size
    return out


def _record(handle: BinaryIO) -> tuple[dict[str, bytes], bytes]:
    head = handle.read(4)
    if len(head) < 4:
        raise NotFast("record cut short")
    left = os.fstat(handle.fileno()).st_size - handle.tell()
    (hlen,) = struct.unpack("<I", head)
    if hlen > left:  # a corrupt length: refuse before allocating
        raise Damaged("record length beyond the end of the file")
    header = handle.read(hlen)
    (dlen,) = struct.unpack("<I", handle.read(4))
    if dlen > left - hlen:
        raise Damaged("record length beyond the end of the file")
    if dlen > MAX_RECORD_BYTES:
        raise Damaged(f"record of {dlen} bytes, longer than any chunk read")
    data = handle.read(dlen)
    if len(header) < hlen or len(data) < dlen:
        raise NotFast("record cut short")
    return _fields(header), data


def _value_offset(buf: bytes, name: bytes) -> int:
    """Offset in a record header of the value of field ``name``."""
    pos = 0
    while pos + 4 <= len(buf):
        (size,) = struct.unpack_from("<I", buf, pos)
        if buf[pos + 4:pos + 5 + len(name)] == name + b"=":
            return pos + 5 + len(name)
        pos += 4 + size
    raise NotFast(f"record header without {name.decode()}")


def _op(header: dict[str, bytes]) -> int:
    return header.get("op", b"\xff")[0]


def _time_ns(value: bytes | None) -> int:
    if value is None or len(value) < 8:
        return 0
    sec, nsec = struct.unpack("<II", value[:8])
    return sec * 1_000_000_000 + nsec


def _u32(value: bytes) -> int:
    return struct.unpack("<I", value[:4])[0]


class Ros1Bag:
    """An indexed ROS 1 bag, read chunk by chunk.

    Raises
    ------
    NotFast
        Not indexed, cut short, or a layout this reader leaves to rosbags.
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.handle = open_handle(self.path, "log", IngestError)
        try:
            self._open()
        except (NotFast, struct.error, KeyError, IndexError, UnicodeDecodeError) as err:
            self.handle.close()
            raise NotFast(str(err)) from err

    def close(self) -> None:
        """Close the file."""
        self.handle.close()

    def _open(self) -> None:
        h = self.handle
        if h.read(len(_MAGIC)) != _MAGIC:
            raise NotFast("bad magic")
        header, _ = _record(h)
        if _op(header) != _OP_HEADER:
            raise NotFast("no bag header")
        index_pos = struct.unpack("<Q", header["index_pos"])[0]
        n_conn, n_chunk = _u32(header["conn_count"]), _u32(header["chunk_count"])
        if index_pos == 0 or n_chunk == 0:
            raise NotFast("bag not indexed")
        h.seek(index_pos)
        self.connections: dict[int, Connection] = {}
        for _ in range(n_conn):
            header, data = _record(h)
            if _op(header) != _OP_CONN:
                raise NotFast("bad connection record")
            info = _fields(data)
            cid = _u32(header["conn"])
            self.connections[cid] = Connection(
                cid, header.get("topic", info.get("topic", b"")).decode(),
                info["type"].decode(), info.get("message_definition", b"").decode())
        self.chunks: list[_Chunk] = []
        for _ in range(n_chunk):
            header, data = _record(h)
            if _op(header) != _OP_CHUNK_INFO or _u32(header["ver"]) != 1:
                raise NotFast("bad chunk info record")
            counts = dict(struct.iter_unpack("<II", data[:8 * _u32(header["count"])]))
            self.chunks.append(_Chunk(struct.unpack("<Q", header["chunk_pos"])[0], counts,
                                      _time_ns(header.get("start_time")),
                                      _time_ns(header.get("end_time"))))
            for cid, n in counts.items():
                self.connections[cid].count += n
        topics = [c.topic for c in self.connections.values()]
        if len(set(topics)) != len(topics):
            raise NotFast("a topic with several connections")

    def chunk_messages(self, chunk: _Chunk) -> tuple[bytes, dict[int, np.ndarray]]:
        """Decompressed chunk and, per connection id, its index entries (``_INDEX``)."""
        h = self.handle
        h.seek(chunk.pos)
        header, data = _record(h)
        if _op(header) != _OP_CHUNK:
            raise Damaged("bad chunk record")
        kind = header.get("compression", b"none").decode("latin-1")
        if kind not in ("lz4", "bz2", "none"):
            raise NotFast(f"compression {kind}")
        if len(header.get("size", b"")) != 4:
            raise Damaged("chunk header without its size")
        got = inflate(kind, data, _u32(header["size"]))
        if got.error:
            raise Damaged(got.error)
        buf = got.data
        index: dict[int, np.ndarray] = {}
        for _ in range(len(chunk.counts)):
            header, data = _record(h)
            if _op(header) != _OP_INDEX or _u32(header["ver"]) != 1:
                raise Damaged("bad index data record")
            cid, count = _u32(header["conn"]), _u32(header["count"])
            index[cid] = np.frombuffer(data, dtype=_INDEX, count=count)
        return buf, index

    def check_order(self) -> np.int64 | None:
        """Verify per-connection time order across chunks; the first record time (ns).

        Reads only the index records (not the chunk bodies).
        """
        last: dict[int, int] = {}
        first: int | None = None
        h = self.handle
        for chunk in self.chunks:
            h.seek(chunk.pos)
            head = h.read(4)
            (hlen,) = struct.unpack("<I", head)
            h.seek(hlen, 1)
            (dlen,) = struct.unpack("<I", h.read(4))
            h.seek(dlen, 1)
            for _ in range(len(chunk.counts)):
                header, data = _record(h)
                cid, count = _u32(header["conn"]), _u32(header["count"])
                entries = np.frombuffer(data, dtype=_INDEX, count=count)
                if not count:
                    continue
                ns = times_ns(entries)
                if (np.diff(ns) < 0).any() or ns[0] < last.get(cid, ns[0]):
                    raise NotFast("messages out of time order")
                last[cid] = int(ns[-1])
                first = int(ns.min()) if first is None else min(first, int(ns.min()))
        return None if first is None else np.int64(first)

    def gather(self, buf: bytes, entries: np.ndarray) -> tuple[np.ndarray | None, list[bytes]]:
        """Bodies of the message records at ``entries``' offsets.

        Returns
        -------
        (array, [])
            uint8 (messages, bytes) when every body has the same length;
        (None, bodies)
            else the bodies as bytes.
        """
        u8 = np.frombuffer(buf, dtype=np.uint8)
        off = entries["offset"].astype(np.int64)
        if len(off) == 0:
            return np.zeros((0, 0), dtype=np.uint8), []
        if off.max() + 8 > len(u8):
            raise Damaged("index offset outside the chunk")
        four = np.arange(4)
        hlen = u8[off[:, None] + four].view("<u4").ravel().astype(np.int64)
        h0 = int(hlen[0])
        if (hlen != h0).any():
            raise NotFast("message record headers differ")
        header = _fields(bytes(buf[off[0] + 4:off[0] + 4 + h0]))
        if _op(header) != _OP_MSG:
            raise Damaged("index points at a non-message record")
        starts = (off + 4).tolist()
        heads = np.frombuffer(b"".join([buf[o:o + h0] for o in starts]),
                              dtype=np.uint8).reshape(-1, h0)
        tpos = _value_offset(bytes(buf[off[0] + 4:off[0] + 4 + h0]), b"time")
        mask = np.ones(h0, dtype=bool)
        mask[tpos:tpos + 8] = False
        if not (heads[:, mask] == heads[0, mask]).all():
            raise NotFast("message record headers differ")
        dpos = off + 4 + h0
        dlen = u8[dpos[:, None] + four].view("<u4").ravel().astype(np.int64)
        start = dpos + 4
        if (start + dlen).max() > len(u8):
            raise Damaged("message outside the chunk")
        if (dlen == dlen[0]).all():
            size = int(dlen[0])
            body = b"".join([buf[s:s + size] for s in start.tolist()])
            return np.frombuffer(body, dtype=np.uint8).reshape(-1, size), []
        return None, [buf[s:s + n] for s, n in zip(start.tolist(), dlen.tolist(), strict=True)]

    def messages(self) -> Iterator[tuple[Connection, np.ndarray, np.ndarray | None,
                                         list[bytes]]]:
        """Per chunk and connection: connection, int64 record times (ns), bodies.

        A damaged chunk is skipped whole and listed in :attr:`lost`.
        """
        self.lost: list[LostChunk] = []
        for chunk in self.chunks:
            try:
                buf, index = self.chunk_messages(chunk)
                out = []
                for cid, entries in index.items():
                    arr, bodies = self.gather(buf, entries)
                    out.append((self.connections[cid], times_ns(entries), arr, bodies))
            except (Damaged, struct.error, KeyError, IndexError) as err:
                self.lost.append(LostChunk(chunk.pos, sum(chunk.counts.values()),
                                           chunk.start_ns, chunk.end_ns, str(err)))
                continue
            yield from out


def times_ns(entries: np.ndarray) -> np.ndarray:
    """int64 ns of index entries (sec, nsec)."""
    return entries["sec"].astype(np.int64) * 1_000_000_000 + entries["nsec"].astype(np.int64)
