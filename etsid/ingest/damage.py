"""One error path for damaged files: what decoders raise on bad bytes, and how it is said.

Every reader keeps what it can (chunks, pages and messages that decode) and notes what it
lost; when nothing at all can be read, :func:`etsid.ingest.read_raw` turns the decoder's
exception into one :class:`~etsid.errors.IngestError` naming the file. The notes say how
much of the recording is missing and where (:func:`lost_note`).
"""

from __future__ import annotations

import sqlite3
import struct
from functools import lru_cache


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


def lost_note(path: object, what: str, start_s: float | None, end_s: float | None) -> str:
    """A coverage note: ``what`` was lost, covering ``start_s``..``end_s`` of the recording.

    Times are seconds from the start of the recording; None when unknown.
    """
    if start_s is None or end_s is None:
        return f"{path}: {what}"
    span = max(0.0, end_s - start_s)
    return (f"{path}: {what}: {span:.1f} s of the recording missing "
            f"(t = {start_s:.1f}–{end_s:.1f} s)")
