"""The numba kernels of :mod:`etsid.ingest.mavlink.scan` (frame scan with CRC check, payload
gathering), in their own module so that reading a small tlog need not import numba."""

from __future__ import annotations

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from etsid.ingest.mavlink.scan import MAGIC_V1, MAGIC_V2, OK, STAMP, UNKNOWN


def _slice_tables(depth: int) -> np.ndarray:
    """CRC-16/MCRF4XX lookup tables for ``depth`` bytes per step (slicing): row 0 is the
    one-byte table (reflected polynomial 0x8408), row k the effect of a byte followed by k
    more bytes."""
    tables = np.zeros((depth, 256), np.int64)
    for i in range(256):
        c = i
        for _ in range(8):
            c = (c >> 1) ^ (0x8408 if c & 1 else 0)
        tables[0, i] = c
    for k in range(1, depth):
        prev = tables[k - 1]
        tables[k] = (prev >> 8) ^ tables[0, prev & 0xFF]
    return tables


_SLICES = _slice_tables(8)
"""Slicing-by-8 tables of :func:`_crc` (the same CRC as the bit formula of the MAVLink
reference, :func:`etsid.ingest.mavlink.scan.crc_x25`, eight bytes per step)."""


@numba.njit(cache=True, nogil=True)
def _crc(buf: np.ndarray, start: int, stop: int, extra: int) -> int:
    """X.25 CRC of ``buf[start:stop]`` followed by ``extra``: eight bytes per step by
    table slicing (one serial table look-up per 8 bytes instead of a chain of shifts per
    byte), the rest a byte at a time."""
    t = _SLICES
    crc = np.int64(0xFFFF)
    i = start
    while i + 8 <= stop:
        crc = (t[7, (np.int64(buf[i]) ^ crc) & 0xFF] ^ t[6, np.int64(buf[i + 1]) ^ (crc >> 8)]
               ^ t[5, buf[i + 2]] ^ t[4, buf[i + 3]] ^ t[3, buf[i + 4]] ^ t[2, buf[i + 5]]
               ^ t[1, buf[i + 6]] ^ t[0, buf[i + 7]])
        i += 8
    if i + 4 <= stop:
        crc = (t[3, (np.int64(buf[i]) ^ crc) & 0xFF] ^ t[2, np.int64(buf[i + 1]) ^ (crc >> 8)]
               ^ t[1, buf[i + 2]] ^ t[0, buf[i + 3]])
        i += 4
    while i < stop:
        crc = (crc >> 8) ^ t[0, (np.int64(buf[i]) ^ crc) & 0xFF]
        i += 1
    return (crc >> 8) ^ t[0, (np.int64(extra) ^ crc) & 0xFF]


@numba.njit(cache=True, nogil=True)
def _frame_size(buf: np.ndarray, m: int) -> int:
    """Bytes of the frame whose magic is at ``m`` (needs buf[m..m+2] in range)."""
    if buf[m] == MAGIC_V1:
        return 8 + buf[m + 1]
    size = 12 + buf[m + 1]
    if buf[m + 2] & 1:
        size += 13
    return size


@numba.njit(cache=True, nogil=True)
def _scan_kernel(buf, n, final, crc_extra, offset, length, msgid, sysid, compid, stamp,
                 status):  # pragma: no cover - compiled
    count = 0
    skipped = 0
    bad_crc = 0
    p = 0
    nextra = crc_extra.size
    while p < n:
        m = p + STAMP
        if m + 3 > n:
            break  # partial record
        magic = buf[m]
        if magic != MAGIC_V1 and magic != MAGIC_V2:
            p += 1
            skipped += 1
            continue
        size = _frame_size(buf, m)
        if m + size > n:
            break  # partial record
        plen = buf[m + 1]
        if magic == MAGIC_V1:
            sid = buf[m + 3]
            cid = buf[m + 4]
            mid = np.int64(buf[m + 5])
            pay = m + 6
        else:
            sid = buf[m + 5]
            cid = buf[m + 6]
            mid = np.int64(buf[m + 7]) | (np.int64(buf[m + 8]) << 8) | (np.int64(buf[m + 9]) << 16)
            pay = m + 10
        end = pay + plen
        extra = crc_extra[mid] if mid < nextra else -1
        if extra >= 0:
            wire = np.int64(buf[end]) | (np.int64(buf[end + 1]) << 8)
            if _crc(buf, m + 1, end, extra) != wire:
                bad_crc += 1
                p += 1
                skipped += 1
                continue
            st = OK
        else:
            # unknown id: trust the length only if the next record starts right after
            nxt = m + size + STAMP
            if nxt < n and buf[nxt] != MAGIC_V1 and buf[nxt] != MAGIC_V2:
                p += 1
                skipped += 1
                continue
            if nxt >= n and not final:
                break  # decide with the next chunk
            st = UNKNOWN
        ts = np.int64(0)
        for k in range(STAMP):
            ts = (ts << 8) | np.int64(buf[p + k])
        offset[count] = pay
        length[count] = plen
        msgid[count] = mid
        sysid[count] = sid
        compid[count] = cid
        stamp[count] = ts
        status[count] = st
        count += 1
        p = m + size
    return count, p, skipped, bad_crc


@numba.njit(cache=True, nogil=True)
def _gather_kernel(buf, offset, length, size, out):  # pragma: no cover - compiled
    for i in range(offset.size):
        start = offset[i]
        n = min(length[i], size)
        for k in range(n):
            out[i, k] = buf[start + k]
        for k in range(n, size):
            out[i, k] = 0


@numba.njit(cache=True, nogil=True)
def _key_stats_kernel(key, stamp, keys, counts, lo, hi):  # pragma: no cover - compiled
    """Distinct values of ``key`` with their count and least and greatest ``stamp``, in
    order of first appearance; −1 when there are more than ``keys.size`` of them."""
    n_keys = 0
    last = -1
    for i in range(key.size):
        n_keys, last = _tally(key[i], stamp[i], n_keys, last, keys, counts, lo, hi)
        if n_keys < 0:
            return -1
    return n_keys


@numba.njit(cache=True, nogil=True)
def _frame_key_stats_kernel(sysid, compid, msgid, stamp, keys, counts, lo, hi
                            ):  # pragma: no cover - compiled
    """:func:`_key_stats_kernel` of the frames' keys ``(sysid << 32) | (compid << 24) |
    msgid``, each made in the pass. The slot of each key is remembered by its message id's
    low 16 bits (frames of several messages interleave, so the previous frame's key is
    rarely the next one's, and a search through the keys per frame took most of the
    time)."""
    n_keys = 0
    hint = np.full(1 << 16, -1, np.int64)
    for i in range(msgid.size):
        k = (np.int64(sysid[i]) << 32) | (np.int64(compid[i]) << 24) | np.int64(msgid[i])
        h = np.int64(msgid[i]) & 0xFFFF
        last = hint[h]
        if last < 0 or keys[last] != k:
            n_keys, last = _tally(k, stamp[i], n_keys, -1, keys, counts, lo, hi)
            if n_keys < 0:
                return -1
            hint[h] = last
            continue
        counts[last] += 1
        s = stamp[i]
        if s < lo[last]:
            lo[last] = s
        if s > hi[last]:
            hi[last] = s
    return n_keys


@numba.njit(cache=True, nogil=True)
def _tally(k, s, n_keys, last, keys, counts, lo, hi):  # pragma: no cover - compiled
    """Count key ``k`` with stamp ``s``; ``last`` is the slot of the previous key. Returns
    the number of keys (−1: no room for a new one) and ``k``'s slot."""
    if last < 0 or keys[last] != k:
        last = -1
        for j in range(n_keys):
            if keys[j] == k:
                last = j
                break
        if last < 0:
            if n_keys == keys.size:
                return -1, last
            last = n_keys
            keys[last] = k
            counts[last] = 0
            lo[last] = s
            hi[last] = s
            n_keys += 1
    counts[last] += 1
    if s < lo[last]:
        lo[last] = s
    if s > hi[last]:
        hi[last] = s
    return n_keys, last


@intrinsic
def _copy_bytes(typingctx, dst, dst_at, src, src_at, n):  # type: ignore[no-untyped-def]
    """``dst[dst_at:dst_at + n] = src[src_at:src_at + n]`` for two distinct contiguous
    uint8 arrays, as one ``memcpy`` (numba's slice copy of a 30-byte payload took 2.5x as
    long); the caller checks the bounds."""
    if not all(isinstance(a, types.Array) and a.layout == "C" and a.dtype == types.uint8
               for a in (dst, src)):
        return None  # (a typing error: the copy below needs contiguous bytes)
    sig = types.void(dst, dst_at, src, src_at, n)

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        d, d_at, s, s_at, count = args
        d_arr = context.make_array(signature.args[0])(context, builder, d)
        s_arr = context.make_array(signature.args[2])(context, builder, s)
        cgutils.raw_memcpy(builder, builder.gep(d_arr.data, [d_at]),
                           builder.gep(s_arr.data, [s_at]), count, 1)

    return sig, codegen


@numba.njit(cache=True, nogil=True)
def _count_kernel(msgid, status, group, ok, counts):  # pragma: no cover - compiled
    """Frames per group: ``counts[group[msgid]] += 1`` for the frames with status ``ok``
    whose id has a group (``group[id]`` ≥ 0; ids past ``group`` have none)."""
    for i in range(msgid.size):
        m = msgid[i]
        if m >= 0 and m < group.size and status[i] == ok:
            g = group[m]
            if g >= 0:
                counts[g] += 1


@numba.njit(cache=True, nogil=True)
def _store_kernel(buf, offset, length, msgid, sysid, compid, stamp, status, group, ok, first,
                  sizes, rbase, fbase, rows, rec, index, stamps, sysids, compids
                  ):  # pragma: no cover - compiled
    """Append each frame of a group (see :func:`_count_kernel`) to its group's region: its
    payload, zero-padded to ``sizes[g]`` bytes, at row ``rows[g]`` of the block of ``rec``
    that starts at ``rbase[g]``; its frame number (``first`` + its position), stamp,
    system and component at ``fbase[g] + rows[g]``. The regions must have room. Two
    passes, the fields then the payloads: one loop doing both ran 2–3x slower."""
    at = rows.copy()
    for i in range(msgid.size):
        m = msgid[i]
        if m < 0 or m >= group.size or status[i] != ok:
            continue
        g = group[m]
        if g < 0:
            continue
        f = fbase[g] + at[g]
        at[g] += 1
        index[f] = first + i
        stamps[f] = stamp[i]
        sysids[f] = sysid[i]
        compids[f] = compid[i]
    _store_payloads(buf, offset, length, msgid, status, group, ok, sizes, rbase, rows, rec)


@numba.njit(cache=True, nogil=True)
def _store_payloads(buf, offset, length, msgid, status, group, ok, sizes, rbase, rows, rec
                    ):  # pragma: no cover - compiled
    """The payload pass of :func:`_store_kernel` (advances ``rows``)."""
    for i in range(msgid.size):
        m = msgid[i]
        if m < 0 or m >= group.size or status[i] != ok:
            continue
        g = group[m]
        if g < 0:
            continue
        r = rows[g]
        rows[g] = r + 1
        size = sizes[g]
        dest = rbase[g] + r * size
        start = offset[i]
        n = min(np.int64(length[i]), size)
        if start + n > buf.size or dest + size > rec.size:
            raise IndexError("frame store: payload out of range")
        _copy_bytes(rec, dest, buf, start, n)
        for k in range(n, size):
            rec[dest + k] = 0
