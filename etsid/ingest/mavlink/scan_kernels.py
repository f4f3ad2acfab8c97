"""The numba kernels of :mod:`etsid.ingest.mavlink.scan` (frame scan with CRC check, payload
gathering), in their own module so that reading a small tlog need not import numba."""

from __future__ import annotations

import numba
import numpy as np

from etsid.ingest.mavlink.scan import MAGIC_V1, MAGIC_V2, OK, STAMP, UNKNOWN


@numba.njit(cache=True, nogil=True)
def _crc(buf: np.ndarray, start: int, stop: int, extra: int) -> int:
    crc = 0xFFFF
    for i in range(start, stop):
        tmp = (buf[i] ^ (crc & 0xFF)) & 0xFF
        tmp = (tmp ^ (tmp << 4)) & 0xFF
        crc = ((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)) & 0xFFFF
    tmp = (extra ^ (crc & 0xFF)) & 0xFF
    tmp = (tmp ^ (tmp << 4)) & 0xFF
    crc = ((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)) & 0xFFFF
    return crc


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
def _gather_grouped_kernel(buf, offset, length, slot, sizes, bases, out
                           ):  # pragma: no cover - compiled
    """One pass over the frames: frame ``i`` of group ``slot[i]`` (−1: none) goes to the
    next row of that group's block of ``out``, which starts at ``bases[slot]`` and has rows
    of ``sizes[slot]`` bytes (zero-padded)."""
    row = np.zeros(sizes.size, np.int64)
    for i in range(offset.size):
        g = slot[i]
        if g < 0:
            continue
        size = sizes[g]
        dest = bases[g] + row[g] * size
        row[g] += 1
        start = offset[i]
        n = min(np.int64(length[i]), size)
        for k in range(n):
            out[dest + k] = buf[start + k]
        for k in range(n, size):
            out[dest + k] = 0
