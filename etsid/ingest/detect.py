"""Pick the reader for a path from its extension, confirmed by the file's magic bytes."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path

from etsid.errors import IngestError
from etsid.files import check, open_binary
from etsid.ingest.base import RawLog, ReadOptions

FORMATS: dict[str, str] = {
    "tlog": "etsid.ingest.mavlink.tlog",
    "bin": "etsid.ingest.dataflash",
    "ulog": "etsid.ingest.ulog",
    "ros1": "etsid.ingest.ros.bag",
    "ros2": "etsid.ingest.ros.bag",
    "mcap": "etsid.ingest.ros.mcap",
}
"""Format name → module with ``read(path, options) -> RawLog``."""

EXTENSIONS = {
    ".tlog": "tlog",
    ".bin": "bin",
    ".ulg": "ulog",
    ".bag": "ros1",
    ".db3": "ros2",
    ".mcap": "mcap",
}

FORMAT_WORDS = {
    "tlog": "a MAVLink telemetry log",
    "bin": "an ArduPilot DataFlash log",
    "ulog": "a PX4 ULog file",
    "ros1": "a ROS 1 bag",
    "ros2": "a ROS 2 bag database (SQLite)",
    "mcap": "an MCAP file",
}
"""Each format in words, for messages (the keys are internal names, not what users know)."""

MAGIC = {
    "bin": b"\xa3\x95",
    "ulog": b"ULog\x01\x12\x35",
    "ros1": b"#ROSBAG V2.0",
    "ros2": b"SQLite format 3\x00",
    "mcap": b"\x89MCAP0\r\n",
}


def _head(path: Path, size: int = 16) -> bytes:
    with open_binary(path, "log", IngestError) as handle:
        try:
            return handle.read(size)
        except OSError as err:
            raise IngestError(f"{path}: cannot read ({err.strerror or err})") from err


def detect_format(path: Path) -> str:
    """Format name of ``path`` (a key of :data:`FORMATS`).

    A directory is a ROS 2 bag when it has ``metadata.yaml``. Files are recognised by
    extension and confirmed by magic bytes; an extension-less file by magic bytes alone.

    Raises
    ------
    IngestError
        Missing, empty, unreadable or unrecognised file, not a regular file (a FIFO
        or device: reading it would never end), or bytes that contradict the
        extension.
    """
    if not path.exists():
        raise IngestError(f"{path}: no such file or directory")
    if path.is_dir():
        odd = sorted(p.name for p in path.iterdir()
                     if p.suffix in (".db3", ".mcap") and not p.is_file())
        if odd:
            raise IngestError(f"{path}: {', '.join(odd[:3])} is not a regular file (a FIFO, "
                              "device or directory): bags are read from files")
        if (path / "metadata.yaml").is_file():
            return "ros2"
        storage = sorted(p.name for p in path.iterdir() if p.suffix in (".db3", ".mcap"))
        hint = f" (it holds {', '.join(storage)}: pass that file instead)" if storage else ""
        raise IngestError(f"{path}: directory without metadata.yaml is not a ROS 2 bag{hint}")
    info = check(path, "log", IngestError).stat()
    if info.st_size == 0:
        raise IngestError(f"{path}: empty file")
    head = _head(path)
    fmt = EXTENSIONS.get(path.suffix.lower())
    if fmt is None:
        for name, magic in MAGIC.items():
            if head.startswith(magic):
                return name
        known = ", ".join(sorted(EXTENSIONS))
        raise IngestError(f"{path}: unknown log format (expected one of {known}, a ROS 2 bag "
                          "directory, or a saved .parquet/.csv table)")
    magic = MAGIC.get(fmt)
    if magic is not None and not head.startswith(magic[: len(head)]):
        raise IngestError(f"{path}: not {FORMAT_WORDS[fmt]} (its first bytes are wrong)")
    if fmt == "tlog" and len(head) > 8 and head[8] not in (0xFE, 0xFD):
        raise IngestError(f"{path}: not a MAVLink telemetry log (no MAVLink packet after the "
                          "first 8-byte timestamp)")
    return fmt


def open_reader(fmt: str) -> Callable[[Path, ReadOptions], RawLog]:
    """The ``read`` function of the reader module for ``fmt``."""
    module = importlib.import_module(FORMATS[fmt])
    return module.read
