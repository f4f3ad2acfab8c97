"""Find MAVLink frames in tlog bytes and check their CRC: a numba kernel plus a plain reference.

A tlog is a sequence of records: an 8-byte big-endian ground-station timestamp (µs since
the Unix epoch) followed by one MAVLink v1 (``0xFE``) or v2 (``0xFD``) frame::

    v1: FE len seq sys comp id                         payload[len] crc[2]
    v2: FD len incompat compat seq sys comp id[3] (LE) payload[len] crc[2] [signature 13]

The CRC is X.25 (CRC-16/MCRF4XX) over the frame after the magic byte, followed by the
message's ``CRC_EXTRA`` seed byte. :func:`scan_frames` walks a byte buffer record by
record; where a record does not start with a magic byte or fails its CRC it moves on one
byte at a time until a valid record starts again, counting what it skipped.

A frame whose message id the dialect does not know cannot be CRC-checked: it is
accepted (and reported as unknown) only when the next record starts right after it.

The numba kernels live in :mod:`.scan_kernels`, imported only when needed: a small buffer
read while numba is not loaded yet is scanned by the plain reference (same result;
:mod:`etsid.ingest.kernel_choice`).
"""

from __future__ import annotations

import binascii
from dataclasses import dataclass

import numpy as np

from etsid.ingest.kernel_choice import use_kernels

MAGIC_V1 = 0xFE
MAGIC_V2 = 0xFD
STAMP = 8
"""Bytes of the ground-station timestamp in front of each frame."""

# status codes per frame
OK = 0
UNKNOWN = 1


@dataclass
class ScanResult:
    """Frames found in one buffer (arrays of length ``count``) and what was skipped."""

    offset: np.ndarray  # int64: index of the payload's first byte
    length: np.ndarray  # int32: payload length on the wire (v2 may be truncated)
    msgid: np.ndarray  # int32
    sysid: np.ndarray  # uint8
    compid: np.ndarray  # uint8
    stamp_us: np.ndarray  # int64: ground-station time, µs since the Unix epoch
    status: np.ndarray  # uint8: OK or UNKNOWN
    consumed: int  # bytes of the buffer that are done (the rest is a partial record)
    skipped: int  # bytes skipped while resynchronising
    bad_crc: int  # frames rejected by their CRC


def scan_arrays(n: int) -> tuple[np.ndarray, ...]:
    """Room for the frames of ``n`` bytes (every record is at least 16 bytes long), for
    :func:`scan_frames`."""
    cap = n // (STAMP + 8) + 1
    return (np.empty(cap, np.int64), np.empty(cap, np.int32), np.empty(cap, np.int32),
            np.empty(cap, np.uint8), np.empty(cap, np.uint8), np.empty(cap, np.int64),
            np.empty(cap, np.uint8))


def scan_frames(buf: np.ndarray, crc_extra: np.ndarray, final: bool,
                arrays: tuple[np.ndarray, ...] | None = None) -> ScanResult:
    """Find the tlog records in ``buf`` (uint8).

    Parameters
    ----------
    buf
        Bytes of the log, starting at a record boundary.
    crc_extra
        ``CRC_EXTRA`` per message id (int16, −1 for ids the dialect lacks).
    final
        True for the last chunk of the file: a trailing partial record is then not
        waited for (the caller counts it as truncated bytes: ``len(buf) - consumed``).
    arrays
        :func:`scan_arrays` to fill (the result's arrays are views of them), reused from
        chunk to chunk; new ones when None or too small.
    """
    if not use_kernels(buf.size):
        return scan_frames_reference(buf.tobytes(), crc_extra, final)
    from etsid.ingest.mavlink.scan_kernels import _scan_kernel

    if arrays is None or arrays[0].size < buf.size // (STAMP + 8) + 1:
        arrays = scan_arrays(buf.size)
    count, consumed, skipped, bad = _scan_kernel(buf, buf.size, final, crc_extra, *arrays)
    off, ln, mid, sid, cid, ts, st = (a[:count] for a in arrays)
    return ScanResult(off, ln, mid, sid, cid, ts, st, int(consumed), int(skipped), int(bad))


_REFLECT = bytes(int(f"{b:08b}"[::-1], 2) for b in range(256))
"""Each byte with its bit order reversed (``bytes.translate`` table)."""


def crc_x25(data: bytes, extra: int) -> int:
    """X.25 CRC (CRC-16/MCRF4XX) of ``data`` followed by the ``extra`` seed byte, at C
    speed: MCRF4XX is the bit-reflected form of CRC-16/CCITT with the same polynomial
    (0x1021) and an all-ones start, so it is ``binascii.crc_hqx`` of the bit-reversed
    bytes, bit-reversed (≈ 1 µs for a 40-byte frame, 19× a byte loop in Python)."""
    crc = binascii.crc_hqx((data + bytes((extra,))).translate(_REFLECT), 0xFFFF)
    return (_REFLECT[crc & 0xFF] << 8) | _REFLECT[crc >> 8]


def scan_frames_reference(data: bytes, crc_extra: np.ndarray, final: bool = True) -> ScanResult:
    """Plain-Python version of :func:`scan_frames`, for equivalence tests (slow)."""
    rows: list[tuple[int, int, int, int, int, int, int]] = []
    skipped = bad = p = 0
    n = len(data)
    while p < n:
        m = p + STAMP
        if m + 3 > n:
            break
        if data[m] not in (MAGIC_V1, MAGIC_V2):
            p, skipped = p + 1, skipped + 1
            continue
        v1 = data[m] == MAGIC_V1
        plen = data[m + 1]
        size = 8 + plen if v1 else 12 + plen + (13 if data[m + 2] & 1 else 0)
        if m + size > n:
            break
        if v1:
            sid, cid, mid, pay = data[m + 3], data[m + 4], data[m + 5], m + 6
        else:
            sid, cid, pay = data[m + 5], data[m + 6], m + 10
            mid = int.from_bytes(data[m + 7:m + 10], "little")
        end = pay + plen
        extra = int(crc_extra[mid]) if mid < crc_extra.size else -1
        if extra >= 0:
            if crc_x25(data[m + 1:end], extra) != int.from_bytes(data[end:end + 2], "little"):
                p, skipped, bad = p + 1, skipped + 1, bad + 1
                continue
            st = OK
        else:
            nxt = m + size + STAMP
            if nxt < n and data[nxt] not in (MAGIC_V1, MAGIC_V2):
                p, skipped = p + 1, skipped + 1
                continue
            if nxt >= n and not final:
                break
            st = UNKNOWN
        rows.append((pay, plen, mid, sid, cid, int.from_bytes(data[p:m], "big"), st))
        p = m + size
    cols = list(zip(*rows, strict=True)) if rows else [()] * 7
    types = (np.int64, np.int32, np.int32, np.uint8, np.uint8, np.int64, np.uint8)
    arrays = [np.asarray(c, dtype=ty) for c, ty in zip(cols, types, strict=True)]
    return ScanResult(*arrays, consumed=p, skipped=skipped, bad_crc=bad)


def gather_payloads(buf: np.ndarray, offset: np.ndarray, length: np.ndarray,
                    size: int) -> np.ndarray:
    """Copy payloads into an (N, size) uint8 array, zero-padding truncated MAVLink 2 payloads."""
    if not use_kernels(buf.size):
        return gather_payloads_reference(buf, offset, length, size)
    from etsid.ingest.mavlink.scan_kernels import _gather_kernel

    out = np.empty((offset.size, size), np.uint8)
    _gather_kernel(buf, offset, length, size, out)
    return out


def key_stats(key: np.ndarray, stamp: np.ndarray, fast: bool
              ) -> tuple[list[int], list[int], list[int], list[int]]:
    """The distinct values of ``key`` (int64) in increasing order, each with its count and
    its least and greatest ``stamp`` (int64). ``fast``: one numba pass (else a stable sort,
    the reference; same result)."""
    if fast and key.size:
        from etsid.ingest.mavlink.scan_kernels import _key_stats_kernel

        keys, counts, lo, hi = (np.empty(KEYS_MAX, np.int64) for _ in range(4))
        n = _key_stats_kernel(key, stamp, keys, counts, lo, hi)
        if n >= 0:
            order = np.argsort(keys[:n])
            return tuple(a[:n][order].tolist() for a in (keys, counts, lo, hi))  # type: ignore
    order = np.argsort(key, kind="stable")
    k, s = key[order], stamp[order]
    starts = np.flatnonzero(np.concatenate(([True], k[1:] != k[:-1])))
    counts = np.diff(np.append(starts, k.size))
    return (k[starts].tolist(), counts.tolist(), np.minimum.reduceat(s, starts).tolist(),
            np.maximum.reduceat(s, starts).tolist())


def frame_key(sysid: np.ndarray, compid: np.ndarray, msgid: np.ndarray) -> np.ndarray:
    """Each frame's (system, component, message) as one int64:
    ``(sysid << 32) | (compid << 24) | msgid``."""
    return (sysid.astype(np.int64) << 32) | (compid.astype(np.int64) << 24) | msgid


def frame_key_stats(sysid: np.ndarray, compid: np.ndarray, msgid: np.ndarray,
                    stamp: np.ndarray, fast: bool
                    ) -> tuple[list[int], list[int], list[int], list[int]]:
    """``key_stats(frame_key(sysid, compid, msgid), stamp, fast)``; ``fast``: the keys are
    made in the numba pass (no key array: 3 casts, 2 shifts and 2 ors of every frame)."""
    if fast and msgid.size:
        from etsid.ingest.mavlink.scan_kernels import _frame_key_stats_kernel

        keys, counts, lo, hi = (np.empty(KEYS_MAX, np.int64) for _ in range(4))
        n = _frame_key_stats_kernel(sysid, compid, msgid, stamp, keys, counts, lo, hi)
        if n >= 0:
            order = np.argsort(keys[:n])
            return tuple(a[:n][order].tolist() for a in (keys, counts, lo, hi))  # type: ignore
    return key_stats(frame_key(sysid, compid, msgid), stamp, fast=False)


KEYS_MAX = 4096
"""Most distinct keys :func:`key_stats` counts in its numba pass (more: the sort)."""


def gather_payloads_reference(buf: np.ndarray, offset: np.ndarray, length: np.ndarray,
                              size: int) -> np.ndarray:
    """Plain-numpy version of :func:`gather_payloads`."""
    out = np.zeros((offset.size, size), np.uint8)
    for i, (start, n) in enumerate(zip(offset, length, strict=True)):
        n = min(int(n), size)
        out[i, :n] = buf[start:start + n]
    return out
