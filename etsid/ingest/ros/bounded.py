"""rosbags' MCAP storage plugin made to decompress through etsid's bounded inflater.

rosbags reads a ROS 2 bag directory with MCAP storage itself (``AnyReader``: at open when
the file has no chunk index, and for each chunk its messages come from). It decompresses a
chunk with ``lz4.frame.decompress`` / ``zstd.decompress`` and compares the size with the
chunk header only afterwards, so an lz4 chunk of a few MB that inflates to gigabytes of
zeros (while its header states 60 KiB) allocates them all first. :func:`install` puts
:func:`etsid.ingest.inflate.inflate` in the plugin's decompressor table: never more output
than the chunk header states, never more than ``MAX_CHUNK_BYTES``; a chunk that says more,
or whose data disagree with it, raises the plugin's own ``ReaderError`` before anything
large is allocated. The bag reader then reads the storage file on with etsid's own MCAP
readers, which skip that chunk and count it in a note.
"""

from __future__ import annotations

from collections.abc import Callable

from etsid.ingest.inflate import inflate

_KINDS = ("lz4", "zstd")


def _bounded(kind: str) -> Callable[[bytes, int], bytes]:
    def decompress(data: bytes, size: int) -> bytes:
        from rosbags.rosbag2.errors import ReaderError

        got = inflate(kind, data, size)
        if got.error:
            raise ReaderError(got.error)
        return got.data

    decompress.__qualname__ = f"etsid_bounded_{kind}"
    return decompress


def install() -> None:
    """Replace the lz4 and zstd entries of rosbags' MCAP decompressor table by bounded
    ones (idempotent; the table is looked up at every chunk).

    Raises
    ------
    RuntimeError
        rosbags no longer has the table this relies on (a version change): better no read
        than an unbounded one; tests/ingest/test_ingest_ros_bounded.py fails first.
    """
    from rosbags.rosbag2 import storage_mcap

    table = getattr(storage_mcap, "DECOMPRESSORS", None)
    if not isinstance(table, dict) or not all(k in table for k in _KINDS):
        raise RuntimeError("rosbags' MCAP storage has no DECOMPRESSORS table: cannot bound "
                           "its chunk decompression")
    for kind in _KINDS:
        table[kind] = _bounded(kind)
