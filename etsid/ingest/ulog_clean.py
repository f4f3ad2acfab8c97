"""What pyulog is given of a ULog file: its message chain, without what would hang or
break pyulog.

pyulog steps one byte at a time (in Python) through bytes that are not messages (in the
definitions section, or where no sync marker follows): gigabytes of zeros after a valid
header run for hours. And a message format that refers to itself (``loop:loop next;``), directly or
through other formats, makes pyulog recurse until Python stops it, losing every topic of
the file. Before pyulog reads a file, :func:`clean` walks its messages (over a
memory map; compiled by :mod:`.ulog_kernels`, in plain Python for a small file while numba
is not loaded, :mod:`etsid.ingest.kernel_choice`):

* where the chain breaks (a message type 0, size 0 or an unknown type longer than
  10 000 bytes, pyulog's own tests), the walk resumes where :data:`RESYNC_MESSAGES`
  messages of known types follow one another (what pyulog finds by stepping a byte at a
  time, found compiled); bytes with no such chain after them end the file;
* formats in or depending on a cycle are replaced by a format of the same name holding
  only a timestamp, so that only the topics using them are lost.

When nothing had to change, pyulog reads the file itself; otherwise it reads the kept
messages from memory (pyulog reads a whole file into memory in any case).
"""

from __future__ import annotations

import mmap
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from etsid.errors import IngestError
from etsid.files import open_binary
from etsid.ingest import mapped
from etsid.ingest.kernel_choice import use_kernels

HEADER_BYTES = 16
RESYNC_MESSAGES = 8
"""Messages of known types in a row that mark where the chain starts again (random bytes
give 8 in a row about once in 10¹⁷ positions: 13 known types of 256, sizes of at most
:data:`RESYNC_MAX_SIZE`)."""
RESYNC_MAX_SIZE = 8192
"""Largest message size accepted while looking for where the chain starts again, bytes."""
_KNOWN = np.zeros(256, dtype=np.bool_)
_KNOWN[[ord(c) for c in "FDIMPQARSOLCB"]] = True
_BASIC = {"int8_t", "uint8_t", "int16_t", "uint16_t", "int32_t", "uint32_t", "int64_t",
          "uint64_t", "float", "double", "bool", "char"}


@dataclass
class Cleaned:
    """The spans of the file pyulog reads and what was left out.

    Attributes
    ----------
    spans : list[tuple[int, int]]
        Byte ranges kept, in order.
    skipped : list[tuple[int, int]]
        Byte ranges that are not messages (position, bytes).
    tail : int
        Bytes at the end that are not messages, with no chain of messages after them.
    cut : int
        Bytes of an incomplete last message.
    recursive : list[str]
        Formats replaced because they refer to themselves (directly or not).
    replace : dict[int, bytes]
        Position of a format message → the message that replaces it.
    """

    spans: list[tuple[int, int]] = field(default_factory=list)
    skipped: list[tuple[int, int]] = field(default_factory=list)
    tail: int = 0
    cut: int = 0
    recursive: list[str] = field(default_factory=list)
    replace: dict[int, bytes] = field(default_factory=dict)

    @property
    def changed(self) -> bool:
        """Whether pyulog must be given something other than the file."""
        return bool(self.skipped or self.tail or self.replace)


def _chain(buf: np.ndarray, pos: int, known: np.ndarray) -> tuple[int, int]:
    """Walk messages from ``pos``: (where the chain stops, 0 at a break / 1 at the end or
    an incomplete last message). Plain Python, compiled by :mod:`.ulog_kernels`."""
    n = buf.size
    while pos + 3 <= n:
        size = np.int64(buf[pos]) | (np.int64(buf[pos + 1]) << 8)
        kind = buf[pos + 2]
        if not known[kind] and (kind == 0 or size == 0 or size > 10000):
            return pos, 0
        if pos + 3 + size > n:
            return pos, 1
        pos += 3 + size
    return pos, 1


def _resync(buf: np.ndarray, first: int, limit: int, known: np.ndarray,
            depth: int) -> int:  # pragma: no cover - run compiled (.ulog_kernels)
    """The first position from ``first`` (below ``limit``) where ``depth`` messages of
    known types follow one another (or fewer that end exactly at the end of the file);
    -1 when the file ends first, -2 when ``limit`` is reached first."""
    n = buf.size
    start = first
    while start + 3 <= n:
        if start >= limit:
            return -2
        at = start
        good = 0
        while good < depth and at + 3 <= n:
            size = np.int64(buf[at]) | (np.int64(buf[at + 1]) << 8)
            if not known[buf[at + 2]] or size == 0 or size > RESYNC_MAX_SIZE \
                    or at + 3 + size > n:
                break
            at += 3 + size
            good += 1
        if good == depth or (good > 0 and at == n):
            return start
        start += 1
    return -1


def clean(path: Path) -> Cleaned:
    """The spans of ``path`` pyulog should read (see the module docstring)."""
    out = Cleaned()
    size = path.stat().st_size
    if size <= HEADER_BYTES:
        out.spans = [(0, size)]
        return out
    with open_binary(path, "log", IngestError) as handle, \
            mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        buf = np.frombuffer(mm, dtype=np.uint8)
        try:
            start = pos = HEADER_BYTES
            chain = _chain
            if use_kernels(size):
                from etsid.ingest.ulog_kernels import chain
            while True:
                stop, whole = (int(v) for v in chain(buf, pos, _KNOWN))
                if whole:
                    out.spans.append((start if out.spans else 0, stop))
                    out.cut = size - stop
                    break
                out.spans.append((start if out.spans else 0, stop))
                resume = _next_chain(mm, buf, stop + 1)
                if resume < 0:
                    out.tail = size - stop
                    break
                out.skipped.append((stop, resume - stop))
                start = pos = resume
            out.recursive, out.replace = _recursive_formats(mm, out.spans)
        finally:
            del buf
    return out


def _next_chain(mm: mmap.mmap, buf: np.ndarray, first: int) -> int:
    """:func:`_resync` (compiled: it steps a byte at a time) a window at a time, the pages
    searched given back (memory stays bounded over gigabytes of garbage)."""
    from etsid.ingest.ulog_kernels import resync

    while True:
        got = resync(buf, first, first + mapped.WINDOW_BYTES, _KNOWN, RESYNC_MESSAGES)
        if got != -2:
            return got
        mapped.release(mm, first, first + mapped.WINDOW_BYTES)
        first += mapped.WINDOW_BYTES


def _recursive_formats(mm: mmap.mmap, spans: list[tuple[int, int]]
                       ) -> tuple[list[str], dict[int, bytes]]:
    """Formats of the definitions section (up to the first subscription) that refer to
    themselves directly or through others, and the replacement of each format message."""
    formats: dict[str, tuple[int, list[str]]] = {}
    for first, end in spans:
        pos = max(first, HEADER_BYTES)
        while pos + 3 <= end:
            size, kind = struct.unpack_from("<HB", mm, pos)
            if kind == ord("A"):
                break
            if kind == ord("F"):
                text = bytes(mm[pos + 3:pos + 3 + size]).decode("utf-8", "replace")
                name, _, body = text.partition(":")
                types = [f.split(" ")[0].split("[")[0] for f in body.split(";") if f.strip()]
                formats[name] = (pos, [t for t in types if t not in _BASIC])
            pos += 3 + size
        else:
            continue
        break
    bad: set[str] = set()
    state: dict[str, int] = {}  # 1: on the current path, 2: done

    def visit(name: str) -> bool:
        """True when ``name`` reaches a cycle."""
        if state.get(name) == 1:
            return True
        if state.get(name) == 2:
            return name in bad
        state[name] = 1
        looped = False
        for sub in formats.get(name, (0, []))[1]:
            if sub in formats and visit(sub):
                looped = True
        state[name] = 2
        if looped:
            bad.add(name)
        return looped

    for name in list(formats):
        try:
            visit(name)
        except RecursionError:  # a chain deeper than Python's stack: pyulog's too
            deep = [n for n, v in state.items() if v == 1]
            bad.update(deep)
            state.update(dict.fromkeys(deep, 2))
    replace = {}
    for name in sorted(bad):
        text = f"{name}:uint64_t timestamp;".encode()
        replace[formats[name][0]] = struct.pack("<HB", len(text), ord("F")) + text
    return sorted(bad), replace


def payload(path: Path, cleaned: Cleaned) -> bytes:
    """The bytes pyulog reads: the kept spans, with replaced format messages."""
    parts: list[bytes] = []
    with open_binary(path, "log", IngestError) as handle, \
            mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as mm:
        for a, b in cleaned.spans:
            pos = a
            for at in sorted(p for p in cleaned.replace if a <= p < b):
                (size,) = struct.unpack_from("<H", mm, at)
                parts.append(mm[pos:at])
                parts.append(cleaned.replace[at])
                pos = at + 3 + size
            parts.append(mm[pos:b])
    return b"".join(parts)
