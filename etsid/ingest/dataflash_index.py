"""Where each message of a DataFlash log starts: an indexer that resynchronises.

pymavlink's compiled indexer stops at the first FMT record whose length is shorter than a
message header (an FMT of length 0 or 1 at the start leaves nothing; in the middle it cuts
the rest of the log), and prints a line per bad byte, which DFReader's callers capture in
an unbounded temporary file. :func:`build_offsets` replaces it (same arguments, same
result: one list of offsets per message type), compiled with numba
(:mod:`.dataflash_kernels`; plain Python for a small log while numba is not loaded):

* an FMT record is accepted only when its length is at least the 3-byte header, its
  format characters are known, their sizes fit in its length and it does not change
  FMT's own length; a rejected FMT is skipped (its 89 bytes) and counted;
* a message of an unknown type, or bytes that are no message header, start a resync at
  the next header of a known type whose message is followed by another header (or by the
  end of the file); the bytes skipped are counted, never printed;
* a message running past the end of the file (a cut log) is listed, as pymavlink does
  (the reader keeps complete messages only and notes the cut).

The counts reach the reader that asked (:data:`STATS`, per thread), for its notes.
:func:`install` makes pymavlink's DFReader use this indexer.
"""

from __future__ import annotations

import contextvars
import mmap
import struct
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from etsid.ingest import mapped
from etsid.ingest.kernel_choice import use_kernels

FMT_TYPE = 0x80
FMT_BYTES = 89
WINDOW_BYTES = 64 << 20
"""Bytes indexed at a time; the pages behind are released (memory stays bounded)."""


@dataclass
class IndexStats:
    """What the indexer of one log skipped."""

    skipped_bytes: int = 0
    stretches: int = 0
    first_skipped: list[int] = field(default_factory=list)
    rejected_fmts: list[int] = field(default_factory=list)


STATS: contextvars.ContextVar[IndexStats | None] = contextvars.ContextVar("dataflash_stats",
                                                                         default=None)
"""Set by the reader around DFReader's indexing; the indexer fills it."""


def _char_sizes() -> np.ndarray:
    from pymavlink.DFReader import FORMAT_TO_STRUCT

    sizes = np.zeros(256, dtype=np.int64)
    for char, (code, _, _) in FORMAT_TO_STRUCT.items():
        sizes[ord(char)] = struct.calcsize("<" + code)
    return sizes


def _grow(arr: np.ndarray, k: int) -> np.ndarray:
    if k < arr.size:
        return arr
    out = np.empty(arr.size * 2, dtype=arr.dtype)
    out[:k] = arr[:k]
    return out


def _fmt_length(buf: np.ndarray, pos: int, sizes: np.ndarray) -> int:
    """Message length an FMT record at ``pos`` defines, or -1 when it is not valid."""
    length = np.int64(buf[pos + 4])
    total = 3
    for i in range(16):
        c = buf[pos + 3 + 1 + 1 + 4 + i]
        if c == 0:
            break
        if sizes[c] == 0:
            return -1
        total += sizes[c]
    if length < 3 or total > length or (buf[pos + 3] == 0x80 and length != 89):
        return -1
    return length


def _index(buf: np.ndarray, pos: int, limit: int, resync: int, head1: int, head2: int,
           sizes: np.ndarray, lengths: np.ndarray
           ) -> tuple[int, int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Index from ``pos`` until ``limit`` (messages may end past it). Plain Python,
    compiled by :mod:`.dataflash_kernels`; run plain on a small log while numba is not
    loaded (:mod:`etsid.ingest.kernel_choice`).

    ``resync``: start of the bad stretch being skipped (-1: none); ``lengths``: message
    length per type, updated by the FMT records met. Returns (where to go on, the resync
    state, offsets, types, skipped stretches as (start, bytes) pairs, rejected FMTs).
    """
    n = buf.size
    offs = np.empty(4096, dtype=np.int64)
    kinds = np.empty(4096, dtype=np.uint8)
    skips = np.empty(64, dtype=np.int64)
    bad_fmt = np.empty(16, dtype=np.int64)
    k = 0
    s = 0
    b = 0
    while pos + 3 <= n and pos < limit:
        if resync < 0:
            kind = buf[pos + 2]
            size = lengths[kind]
            if buf[pos] == head1 and buf[pos + 1] == head2 and size > 0:
                if pos + size > n:  # cut short: listed (as pymavlink does), then the end
                    offs = _grow(offs, k)
                    kinds = _grow(kinds, k)
                    offs[k] = pos
                    kinds[k] = kind
                    k += 1
                    pos = n
                    break
                if kind == 0x80:
                    flen = _fmt_length(buf, pos, sizes)
                    if flen < 0:
                        bad_fmt = _grow(bad_fmt, b)
                        bad_fmt[b] = pos
                        b += 1
                        pos += size
                        continue
                    lengths[buf[pos + 3]] = flen
                offs = _grow(offs, k)
                kinds = _grow(kinds, k)
                offs[k] = pos
                kinds[k] = kind
                k += 1
                pos += size
                continue
            resync = pos
            pos += 1
        # resync: the next known header followed by another one (or by the end)
        while pos + 3 <= n and pos < limit:
            if buf[pos] == head1 and buf[pos + 1] == head2:
                ln = lengths[buf[pos + 2]]
                if ln > 0:
                    nxt = pos + ln
                    if nxt == n or (nxt + 3 <= n and buf[nxt] == head1
                                    and buf[nxt + 1] == head2 and lengths[buf[nxt + 2]] > 0):
                        break
            pos += 1
        if pos + 3 <= n and pos < limit:  # found
            skips = _grow(skips, 2 * s + 1)
            skips[2 * s] = resync
            skips[2 * s + 1] = pos - resync
            s += 1
            resync = -1
    if resync >= 0 and pos + 3 > n:  # bad bytes up to the end
        skips = _grow(skips, 2 * s + 1)
        skips[2 * s] = resync
        skips[2 * s + 1] = n - resync
        s += 1
        resync = -1
    return pos, resync, offs[:k], kinds[:k], skips[:2 * s], bad_fmt[:b]


def build_offsets(data: Any, fmt_type: int, fmt_len: int, type_offset: int, size_offset: int,
                  head1: int, head2: int, progress_callback: Any = None) -> list[list[int]]:
    """Offsets of every message, one list per message type (pymavlink's indexer's
    signature and result; FMT at type 0x80 with the standard 89-byte layout)."""
    if (fmt_type, fmt_len, type_offset, size_offset) != (FMT_TYPE, FMT_BYTES, 3, 4):
        raise ValueError("unexpected FMT layout")
    buf = np.frombuffer(data, dtype=np.uint8)
    owner = data.obj if isinstance(data, memoryview) else data
    lengths = np.zeros(256, dtype=np.int64)
    lengths[FMT_TYPE] = FMT_BYTES
    parts: list[tuple[np.ndarray, ...]] = []
    pos, resync, done = 0, -1, 0
    index = _index
    if use_kernels(buf.size):
        from etsid.ingest.dataflash_kernels import index
    try:
        while pos + 3 <= buf.size:
            pos, resync, *found = index(buf, pos, pos + WINDOW_BYTES, resync, head1, head2,
                                         _SIZES, lengths)
            parts.append(tuple(found))
            if isinstance(owner, mmap.mmap):  # pages behind are not needed again here
                mapped.release(owner, done, pos)
                done = pos
    finally:
        del buf
    offs, kinds, skips, bad_fmt = (np.concatenate([p[i] for p in parts]) if parts else
                                   np.empty(0, dtype=np.int64) for i in range(4))
    kinds = kinds.astype(np.uint8)
    stats = STATS.get()
    if stats is not None:
        stats.skipped_bytes = int(skips[1::2].sum())
        stats.stretches = len(skips) // 2
        stats.first_skipped = skips[0::2][:5].tolist()
        stats.rejected_fmts = bad_fmt.tolist()
    order = np.argsort(kinds, kind="stable")
    counts = np.bincount(kinds, minlength=256)
    split = np.split(offs[order], np.cumsum(counts)[:-1])
    return [part.tolist() for part in split]


_SIZES = _char_sizes()


class _Indexer:
    """Stands in for ``pymavlink.dfindexer`` (module attributes ``available`` and
    ``build_offsets``)."""

    available = True
    build_offsets = staticmethod(build_offsets)


def install() -> None:
    """Make pymavlink's DFReader index DataFlash logs with :func:`build_offsets`."""
    from pymavlink import DFReader

    DFReader.dfindexer = _Indexer
