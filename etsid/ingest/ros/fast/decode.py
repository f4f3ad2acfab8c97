"""Vectorised decoding of fixed-layout ROS messages (ROS 1 and CDR), a batch at a time.

The slow path deserialises every message into Python objects (rosbags) and pulls the
numbers out one message at a time. Most flight-data topics carry messages whose layout
never changes within a topic: the only variable parts are ``header.frame_id`` and short
arrays (RC channels) whose lengths are constant. For such a batch this module:

1. walks the type definition over the *first* message of the batch to find every field's
   byte offset (ROS 1: packed little-endian; CDR: little-endian, each primitive aligned to
   its size relative to the end of the 4-byte encapsulation header, string and sequence
   lengths uint32 aligned to 4);
2. checks that every message of the batch has the same length, the same string/sequence
   lengths and (CDR) the little-endian encapsulation, so the same offsets hold for all;
3. reads the whole batch with one numpy structured dtype (:func:`numpy.frombuffer`) and
   builds the converter's rows with the vectorised row functions of
   :mod:`etsid.ingest.ros.fast.rows`.

Anything else (lengths differing within the batch, big-endian CDR, types without a
vectorised row function, ``--map`` field requests, unsupported field types) returns
``False`` and the caller takes the per-message path. Both paths give bit-identical
signals (tested with the fast path forced off: ``ETSID_ROS_FAST=0`` or
:data:`ENABLED`).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from etsid.ingest.ros.converter import Converter, TopicData
from etsid.ingest.ros.fast.rows import FAST_ROWS, fast_clock
from etsid.ingest.ros.messages import message_type

ENABLED = os.environ.get("ETSID_ROS_FAST", "1") not in ("0", "false", "no", "off")
"""Master switch of the vectorised path (tests force it off to compare)."""
BATCH = 50_000
"""Messages per batch: memory stays bounded by the output, overheads stay negligible."""

STATS = {"fast": 0, "slow": 0}
"""Messages converted by the vectorised and (through :class:`Batcher`) the per-message
path in this process (for tests and benchmarks)."""

_PRIMITIVES = {"bool": "u1", "int8": "i1", "uint8": "u1", "int16": "<i2", "uint16": "<u2",
               "int32": "<i4", "uint32": "<u4", "int64": "<i8", "uint64": "<u8",
               "float32": "<f4", "float64": "<f8"}
_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4


class Unsupported(Exception):
    """The message layout cannot be read as one fixed structure."""


@dataclass
class Layout:
    """Byte layout of one message instance.

    Attributes
    ----------
    size : int
        Message length, bytes.
    fields : dict[str, tuple[int, str, int]]
        Dotted field path → (offset in bytes, numpy dtype string, element count; 0 for a
        scalar).
    checks : list[int]
        Byte offsets that must be equal in every message of a batch (string and sequence
        lengths, the CDR encapsulation).
    """

    size: int
    fields: dict[str, tuple[int, str, int]] = field(default_factory=dict)
    checks: list[int] = field(default_factory=list)

    def dtype(self) -> np.dtype:
        """Numpy structured dtype reading every numeric field of the message."""
        names = list(self.fields)
        formats = [(np.dtype(d), (n,)) if n else np.dtype(d) for _, d, n in self.fields.values()]
        offsets = [o for o, _, _ in self.fields.values()]
        return np.dtype({"names": names, "formats": formats, "offsets": offsets,
                         "itemsize": self.size})


class _Walker:
    """Walk a rosbags type definition over one serialised message."""

    def __init__(self, fielddefs: dict[str, Any], buf: bytes, cdr: bool) -> None:
        self.defs, self.buf, self.cdr = fielddefs, buf, cdr
        self.layout = Layout(len(buf))
        self.pos = 4 if cdr else 0
        if cdr:
            if len(buf) < 4 or buf[0] != 0 or buf[1] != 1:
                raise Unsupported("not little-endian CDR")
            self.layout.checks += [0, 1]

    def align(self, size: int) -> None:
        if self.cdr and size > 1:
            self.pos = 4 + ((self.pos - 4 + size - 1) & -size)

    def length(self) -> int:
        self.align(4)
        if self.pos + 4 > len(self.buf):
            raise Unsupported("message shorter than its definition")
        value = int.from_bytes(self.buf[self.pos:self.pos + 4], "little")
        self.layout.checks += range(self.pos, self.pos + 4)
        self.pos += 4
        return value

    def primitive(self, path: str, name: str, count: int) -> None:
        dtype = _PRIMITIVES.get(name)
        if dtype is None:
            raise Unsupported(f"field type {name}")
        size = np.dtype(dtype).itemsize
        self.align(size)
        self.layout.fields[path] = (self.pos, dtype, count)
        self.pos += size * max(count, 1)

    def string(self) -> None:
        size = self.length()
        self.pos += size

    def message(self, typename: str, prefix: str) -> None:
        if typename not in self.defs:
            raise Unsupported(f"no definition of {typename}")
        for name, (kind, detail) in self.defs[typename][1]:
            path = prefix + name
            if kind == _BASE:
                if detail[0] == "string":
                    self.string()
                else:
                    self.primitive(path, detail[0], 0)
            elif kind == _NAME:
                self.message(detail, path + ".")
            elif kind in (_ARRAY, _SEQUENCE):
                (sub_kind, sub), count = detail
                if kind == _SEQUENCE:
                    count = self.length()
                if sub_kind == _BASE and sub[0] != "string":
                    if count == 0:  # nothing read: no alignment, no field
                        continue
                    self.primitive(path, sub[0], count)
                elif sub_kind == _BASE:
                    for _ in range(count):
                        self.string()
                else:
                    for i in range(count):
                        self.message(sub, f"{path}[{i}].")
            else:
                raise Unsupported(f"field kind {kind}")
            if self.pos > len(self.buf):
                raise Unsupported("message shorter than its definition")


def layout_of(fielddefs: dict[str, Any], typename: str, buf: bytes, cdr: bool) -> Layout:
    """Layout of the serialised message ``buf`` of ``typename``.

    Raises
    ------
    Unsupported
        A field type that is not a fixed-size number or a string, or bytes that do not fit.
    """
    walker = _Walker(fielddefs, buf, cdr)
    walker.message(typename, "")
    if walker.pos != len(buf) and not (cdr and len(buf) - walker.pos < 4):
        raise Unsupported("message length disagrees with its definition")
    return walker.layout


class Cols:
    """Attribute access to the columns of a decoded batch, like a message object.

    ``cols.header.stamp.sec`` is the int32 array of every message's ``header.stamp.sec``;
    array fields are 2-D (message, element). A field the definition lacks raises
    :class:`AttributeError` (so ``hasattr`` works as on a message).
    """

    def __init__(self, rec: np.ndarray, prefix: str = "") -> None:
        self._rec, self._prefix = rec, prefix

    def __len__(self) -> int:
        """Number of messages in the batch."""
        return len(self._rec)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        key = self._prefix + name
        names = self._rec.dtype.names or ()
        if key in names:
            return self._rec[key]
        if any(n.startswith(key + ".") for n in names):
            return Cols(self._rec, key + ".")
        raise AttributeError(name)


def fast_kind(topic: TopicData) -> str | None:
    """The message kind when ``topic`` can take the vectorised path at all."""
    if not ENABLED or topic.spec is None or topic.requests:
        return None
    kind = message_type(topic.msgtype)
    return kind if kind in FAST_ROWS else None


def decode_batch(conv: Converter, topic: TopicData, fielddefs: dict[str, Any], typename: str,
                 data: np.ndarray, log_ns: np.ndarray, cdr: bool) -> bool:
    """Convert a batch of same-length messages; False when it needs the per-message path.

    Parameters
    ----------
    conv, topic
        The converter and the topic the messages belong to.
    fielddefs, typename
        rosbags type definitions (``typestore.fielddefs``) and the message's type name.
    data : numpy.ndarray
        uint8 array (messages, bytes per message): the serialised messages.
    log_ns : numpy.ndarray
        int64 record (log) times, ns.
    cdr : bool
        CDR (ROS 2) rather than ROS 1 serialisation.
    """
    kind = fast_kind(topic)
    if kind is None or len(data) == 0:
        return False
    try:
        layout = layout_of(fielddefs, typename, data[0].tobytes(), cdr)
        if layout.checks:
            idx = np.asarray(layout.checks)
            if not (data[:, idx] == data[0, idx]).all():
                return False
        rec = np.ascontiguousarray(data).reshape(-1).view(layout.dtype())
        cols = Cols(rec)
        rows = FAST_ROWS[kind](cols)
        stamps = fast_clock(topic.spec, cols)
    except (Unsupported, AttributeError, KeyError, ValueError, TypeError, IndexError):
        return False
    conv.add_rows(topic, stamps, np.asarray(log_ns, dtype=np.int64), rows)
    STATS["fast"] += len(data)
    return True


def same_length(datas: list[bytes]) -> np.ndarray | None:
    """The messages as one (messages, bytes) uint8 array, or None when lengths differ."""
    sizes = set(map(len, datas))
    if len(sizes) != 1:
        return None
    return np.frombuffer(b"".join(datas), dtype=np.uint8).reshape(len(datas), sizes.pop())


class Batcher:
    """Collect raw messages per topic and convert them a batch at a time.

    Parameters
    ----------
    conv : Converter
        Receives the rows.
    slow : callable
        ``slow(topic, state, data, log_ns)`` converts one message the per-message way.
    """

    def __init__(self, conv: Converter, slow: Callable[[TopicData, Any, bytes, int], None]
                 ) -> None:
        self.conv, self.slow = conv, slow
        self.pending: dict[str, tuple[TopicData, Any, Any, list[bytes], list[int]]] = {}

    def push(self, topic: TopicData, fast: tuple[dict[str, Any], str, bool] | None,
             state: Any, data: bytes, log_ns: int) -> None:
        """Queue one message.

        ``fast`` is (fielddefs, typename, cdr) when the vectorised path may be tried,
        ``state`` whatever ``slow`` needs.
        """
        if self.conv.base_ns is None:
            self.conv.base_ns = log_ns
        entry = self.pending.get(topic.topic)
        if entry is None:
            entry = self.pending[topic.topic] = (topic, fast, state, [], [])
        entry[3].append(data)
        entry[4].append(log_ns)
        if len(entry[3]) >= BATCH:
            self.flush(topic.topic)

    def flush(self, name: str) -> None:
        """Convert the queued messages of topic ``name``."""
        entry = self.pending.pop(name, None)
        if entry is None:
            return
        topic, fast, state, datas, logs = entry
        if fast is not None and fast_kind(topic) is not None:
            arr = same_length(datas)
            if arr is not None and decode_batch(self.conv, topic, fast[0], fast[1], arr,
                                                np.asarray(logs, dtype=np.int64), fast[2]):
                return
        STATS["slow"] += len(datas)
        for data, log_ns in zip(datas, logs, strict=True):
            self.slow(topic, state, data, log_ns)

    def flush_all(self) -> None:
        """Convert everything still queued."""
        for name in list(self.pending):
            self.flush(name)
