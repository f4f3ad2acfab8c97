"""Bounded decompression of one chunk (zstd, lz4, bz2): never more output than a cap.

A chunk header declares how many bytes its data decompress to, but the compressed stream
need not agree: a zstd frame carries its own content size, an lz4 or bz2 stream has no
limit at all, and a few kilobytes of zeros inflate to gigabytes. Every reader of
compressed chunks (MCAP, ROS 1 bags) decompresses through :func:`inflate`, which streams
the output in steps and stops at the smaller of the declared size and
:data:`MAX_CHUNK_BYTES`, once per chunk: what it returns serves both the strict reading of
a whole chunk and the salvage of its readable start.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

MAX_CHUNK_BYTES = int(float(os.environ.get("ETSID_MAX_CHUNK_MB", "128")) * (1 << 20))
"""Largest decompressed chunk read, bytes (``ETSID_MAX_CHUNK_MB``, default 128 MiB).
A chunk declaring more is skipped whole, before anything is decompressed; ROS and MCAP
writers make chunks of about 1 MiB (one larger message makes one larger chunk)."""
MAX_RECORD_BYTES = MAX_CHUNK_BYTES + (1 << 20)
"""Longest record read whole (a chunk's compressed bytes, a message): compressed data
never grows beyond its content by more than a fraction, so a longer record is damaged."""
STEP_BYTES = 1 << 20
"""Output asked of an lz4 or bz2 decompressor at a time, bytes."""
FEED_BYTES = 4096
"""Compressed bytes given to an lz4 or bz2 decompressor at a time (what precedes a
damaged block is kept)."""
ZSTD_FEED = 1024
"""Compressed bytes given to zstd at a time: their output is at most 32 MiB (a 4-byte
run-length block per 128 KiB)."""


@dataclass
class Inflated:
    """What one chunk decompressed to.

    Attributes
    ----------
    data : bytes
        The whole output, or its start when ``error`` is set (never more than the cap).
    error : str
        Empty when the stream ended with exactly the declared size; else what went wrong
        ("decompresses to more than the declared …", a decoder's message, …).
    """

    data: bytes
    error: str = ""


def too_large(declared: int) -> str:
    """The reason a chunk declaring ``declared`` bytes is not read, or ``""``."""
    if declared > MAX_CHUNK_BYTES:
        return (f"chunk declares {declared} bytes decompressed, above the limit of "
                f"{MAX_CHUNK_BYTES >> 20} MiB (ETSID_MAX_CHUNK_MB)")
    return ""


def inflate(kind: str, data: bytes | memoryview, declared: int) -> Inflated:
    """Decompress one chunk's ``data`` (``kind``: ``zstd``, ``lz4``, ``bz2``, or ``""`` /
    ``none`` for stored bytes) to at most ``declared`` bytes (the size its header states)
    and never more than :data:`MAX_CHUNK_BYTES`.

    Raises
    ------
    ValueError
        An unknown compression ``kind``.
    """
    if (why := too_large(declared)) or declared < 0:
        return Inflated(b"", why or "negative declared size")
    if kind in ("", "none"):
        out = bytes(data)
        return Inflated(out[:declared], "" if len(out) == declared else
                        f"chunk holds {len(out)} bytes, not the declared {declared}")
    out = bytearray()
    error = ""
    try:
        _decompress_into(kind, bytes(data), out, declared + 1)
    except ValueError as err:
        if str(err).startswith("unknown compression"):
            raise
        error = _failure(kind, err)
    except Exception as err:  # any decoder failure: keep what came out before it
        error = _failure(kind, err)
    if len(out) > declared:
        return Inflated(bytes(out[:declared]), f"chunk decompresses to more than the "
                        f"declared {declared} bytes")
    if not error and len(out) != declared:
        error = f"chunk decompresses to {len(out)} bytes, not {declared}"
    return Inflated(bytes(out), error)


def _failure(kind: str, err: Exception) -> str:
    text = " ".join(str(a) for a in err.args).strip() or type(err).__name__
    return f"{kind} chunk does not decompress ({text.splitlines()[0][:120]})"


def _decompress_into(kind: str, data: bytes, out: bytearray, limit: int) -> None:
    """Append the decompressed ``data`` to ``out`` until it ends or ``out`` holds
    ``limit`` bytes (zstd: at most :data:`ZSTD_FEED` compressed bytes at a time, whose
    output is bounded, so that what precedes a damaged block is kept)."""
    if kind == "zstd":
        import zstandard

        zobj = zstandard.ZstdDecompressor().decompressobj()
        for at in range(0, len(data), ZSTD_FEED):
            out += zobj.decompress(data[at:at + ZSTD_FEED])
            if len(out) >= limit or zobj.eof:
                return
        return
    if kind == "lz4":
        import lz4.frame

        dec: Any = lz4.frame.LZ4FrameDecompressor()
    elif kind == "bz2":
        import bz2

        dec = bz2.BZ2Decompressor()
    else:
        raise ValueError(f"unknown compression {kind[:20]!r}")
    at = 0
    while len(out) < limit and not dec.eof:
        feed = b""
        if dec.needs_input:
            if at >= len(data):
                return
            feed, at = data[at:at + FEED_BYTES], at + FEED_BYTES
        out += dec.decompress(feed, max_length=min(STEP_BYTES, limit - len(out)))
