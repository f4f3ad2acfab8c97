"""Files read through a memory map whose searched pages do not stay resident.

A damaged log is searched for the next record that starts again (ROS 1 bags, MCAP files);
over gigabytes of zeros or garbage a plain ``find`` on a map touches every page, and the
resident set grows to the file's size. :func:`find` searches in windows and gives the
pages behind it back to the kernel, so memory stays bounded whatever the file's size.
"""

from __future__ import annotations

import contextlib
import mmap
from typing import Any

WINDOW_BYTES = 64 << 20
"""Bytes searched at a time before the pages are released."""


def find(buf: Any, needle: bytes, start: int, end: int | None = None) -> int:
    """``buf.find(needle, start, end)``; on a memory map, pages searched are released."""
    if not isinstance(buf, mmap.mmap):
        return buf.find(needle, start, len(buf) if end is None else end)
    end = len(buf) if end is None else min(end, len(buf))
    pos = start
    while pos < end:
        stop = min(end, pos + WINDOW_BYTES + len(needle) - 1)
        hit = buf.find(needle, pos, stop)
        if hit >= 0:
            return hit
        release(buf, pos, stop - len(needle) + 1)
        pos = stop - len(needle) + 1
        if stop >= end:
            break
    return -1


def release(buf: mmap.mmap, start: int, stop: int) -> None:
    """Give the whole pages of ``buf[start:stop]`` back (read-only maps: read again from
    the file when touched later)."""
    first = -(-start // mmap.PAGESIZE) * mmap.PAGESIZE
    last = stop // mmap.PAGESIZE * mmap.PAGESIZE
    if last > first and hasattr(buf, "madvise"):
        # where unsupported, memory is only slower to come back
        with contextlib.suppress(OSError, ValueError):
            buf.madvise(mmap.MADV_DONTNEED, first, last - first)
