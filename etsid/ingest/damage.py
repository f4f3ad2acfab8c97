"""One error path for damaged files: what decoders raise on bad bytes, and how it is said.

Every reader keeps what it can (chunks, pages and messages that decode) and notes what it
lost; when nothing at all can be read, :func:`etsid.ingest.read_raw` turns the decoder's
exception into one :class:`~etsid.errors.IngestError` naming the file. The notes say how
much of the recording is missing and where, in one wording for every format
(:func:`gap_note` for data skipped inside a recording, :func:`cut_note` for a cut end).
"""

from __future__ import annotations

import math
import sqlite3
import struct
from collections.abc import Sequence
from functools import lru_cache

import numpy as np


@lru_cache(maxsize=1)
def decoder_errors() -> tuple[type[BaseException], ...]:
    """Exception types that decoders and storage layers raise on damaged bytes.

    ``TypeError`` is what damaged typed values give (a NULL or blob timestamp in a db3 row,
    a string where metadata.yaml holds a number); ``RuntimeError`` is what lz4 raises on
    a bad frame, ``OverflowError``/``MemoryError``
    what a third-party layer (rosbags, sqlite) raises on a corrupt 64-bit length it tries
    to seek to or allocate; etsid's own decoders check lengths against the bytes left
    before allocating.
    """
    errors: list[type[BaseException]] = [
        OSError, EOFError, ValueError, TypeError, struct.error, KeyError, IndexError,
        RuntimeError, OverflowError, MemoryError, AssertionError, sqlite3.Error,
    ]
    try:
        import zstandard

        errors.append(zstandard.ZstdError)
    except ImportError:  # pragma: no cover - zstandard ships with mcap
        pass
    try:
        import apsw  # rosbags' SQLite binding for ROS 2 .db3 storage

        errors.append(apsw.Error)
    except ImportError:  # pragma: no cover - not every rosbags install uses apsw
        pass
    try:
        from rosbags.highlevel import AnyReaderError
        from rosbags.rosbag1 import ReaderError as Reader1Error
        from rosbags.rosbag2 import ReaderError as Reader2Error
        from rosbags.serde import SerdeError
        from rosbags.typesys import TypesysError

        errors.extend((AnyReaderError, Reader1Error, Reader2Error, SerdeError, TypesysError))
    except ImportError:  # pragma: no cover - rosbags is a dependency
        pass
    return tuple(errors)


def describe(err: BaseException) -> str:
    """One line saying what a decoder reported, e.g. ``Data corruption detected``."""
    if isinstance(err, MemoryError):
        return "a corrupt length asks for more memory than there is"
    if isinstance(err, OverflowError):
        return "a corrupt length or offset beyond 64 bits"
    text = " ".join(str(a) for a in err.args) if err.args else ""
    text = text.strip().splitlines()[0] if text.strip() else type(err).__name__
    return text[:200]


def _where(spans: Sequence[tuple[float, float]]) -> str:
    text = ", ".join(f"{a:.1f}–{b:.1f} s" for a, b in spans[:5])
    return text + (" …" if len(spans) > 5 else "")


def gap_note(path: object, what: str, gaps: Sequence[tuple[float, float]],
             first_s: float | None = None, last_s: float | None = None) -> str:
    """The one coverage note for data skipped inside a recording.

    ``what`` says what was skipped (``skipped 3 damaged chunk(s) at byte …``); ``gaps``
    are the time spans the skipped data covered (s from the start of the recording: the
    last sample kept before each damage to the first kept after it); ``first_s`` and
    ``last_s`` are the first and last sample kept. Example: ``log.mcap: skipped 1 damaged
    chunk(s) …; 5.3 s missing (t = 15.9–21.2 s); data cover 30.7 s of the 36.0 s between
    first and last message``.
    """
    spans = [(float(a), float(b)) for a, b in gaps
             if math.isfinite(a) and math.isfinite(b) and b >= a]
    text = f"{path}: {what}"
    lost = sum(b - a for a, b in spans)
    if spans:
        text += f"; {lost:.1f} s missing (t = {_where(spans)})"
    if first_s is not None and last_s is not None and math.isfinite(first_s) \
            and math.isfinite(last_s) and last_s > first_s:
        span = last_s - first_s
        text += (f"; data cover {max(0.0, span - lost):.1f} s of the {span:.1f} s between "
                 "first and last message")
    return text


def cut_note(path: object, what: str, messages: int, first_s: float | None,
             last_s: float | None, total_s: float | None = None) -> str:
    """The one note for a recording cut short: what was kept, in messages and seconds.

    ``total_s``: the length of the whole recording when something (a ROS 2 bag's
    metadata.yaml) still says it; else the note says the rest is lost. Example:
    ``bag: truncated storage file …: kept 2655 message(s), 10.5 s of 36.0 s``.
    """
    text = f"{path}: {what}: kept {messages} message(s)"
    if first_s is None or last_s is None or not (math.isfinite(first_s)
                                                 and math.isfinite(last_s)):
        return text
    kept = max(0.0, last_s - first_s)
    if total_s is not None and math.isfinite(total_s) and total_s > 0:
        return text + (f", {kept:.1f} s of {total_s:.1f} s "
                       f"({max(0.0, total_s - kept):.1f} s lost at the end)")
    return text + f", {kept:.1f} s; the rest of the recording is lost"


def data_gaps(t: np.ndarray, factor: float = 3.0,
              floor_s: float = 0.02) -> list[tuple[float, float]]:
    """Spans where a regular stream (s, sorted) has no samples: steps longer than
    ``factor`` times its median step and than ``floor_s``. Used where a decoder skips
    damaged bytes without saying where (pyulog, pymavlink's DataFlash reader)."""
    t = np.asarray(t, dtype=np.float64)
    t = t[np.isfinite(t)]
    if t.size < 3:
        return []
    step = np.diff(t)
    typical = float(np.median(step[step > 0])) if (step > 0).any() else 0.0
    big = np.flatnonzero(step > max(factor * typical, floor_s))
    return [(float(t[i]), float(t[i + 1])) for i in big.tolist()]


def stream_gap_note(path: object, what: str, streams: Sequence[np.ndarray],
                    known: Sequence[tuple[float, float]] = ()) -> str:
    """:func:`gap_note` for a decoder that skips damaged bytes without saying where: the
    gaps are those of the densest stream in ``streams`` (sample times, s), with times from
    its first sample; gaps that overlap a ``known`` span (s, same clock as ``streams``:
    a logger dropout the log itself reports) are not counted as damage."""
    dense = max((np.asarray(t, dtype=np.float64) for t in streams), key=len,
                default=np.empty(0))
    dense = np.sort(dense[np.isfinite(dense)])
    if dense.size < 3:
        return f"{path}: {what}"
    t0 = float(dense[0])
    gaps = [(a - t0, b - t0) for a, b in data_gaps(dense)
            if not any(a <= kb and ka <= b for ka, kb in known)]
    return gap_note(path, what + " (gaps in its densest stream)" if gaps else what, gaps,
                    0.0, float(dense[-1]) - t0)
