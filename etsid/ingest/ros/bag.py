"""ROS 1 ``.bag`` and ROS 2 bags (directory with metadata.yaml, or a ``.db3`` storage file).

Read with rosbags' :class:`~rosbags.highlevel.AnyReader`, streaming; each message is
decoded only when its type maps to FlightTable columns (see
:mod:`etsid.ingest.ros.messages` for types, frames, times and priorities) or a ``--map``
asks for one of its fields. Messages are converted a batch per topic at a time: batches of
same-length hot-type messages with numpy (:mod:`etsid.ingest.ros.fast.decode`), the rest one by
one with rosbags' deserialisers. Indexed ROS 1 bags are read by
:mod:`etsid.ingest.ros.fast.ros1` and one-file ROS 2 bags straight from their storage by
:mod:`etsid.ingest.ros.fast.ros2` when their layout allows it (same signals, verified).

Definitions: those embedded in the bag (ROS 1 connection headers, ROS 2 metadata or
storage schemas); for bags without them, ROS 2 Humble's standard types plus the shipped
mavros_msgs / px4_msgs definitions (``etsid/rosmsgs/msgdefs``, :mod:`etsid.rosmsgs`).

Real-world quirks handled:

* a ROS 2 bag whose metadata.yaml is unusable (a storage path that does not exist, old
  layout) or disagrees with its storage file (QoS/format: rosbags then yields zero
  messages) is read again from its storage file(s) directly, with a warning;
* a ROS 1 bag cut off before its index (truncated) is scanned chunk by chunk: the valid
  part is kept, a warning gives the bytes that could not be read;
* a topic whose messages cannot be decoded is skipped, counted and noted.
"""

from __future__ import annotations

import bz2
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from etsid.errors import IngestError
from etsid.ingest.base import RawLog, ReadOptions
from etsid.ingest.ros.converter import Converter, TopicData
from etsid.ingest.ros.fast import decode as fast
from etsid.ingest.ros.fast import mcap as fast_mcap
from etsid.ingest.ros.fast import ros2 as fast_ros2
from etsid.ingest.ros.fast.decode import Batcher
from etsid.ingest.ros.fast.ros1 import NotFast, Ros1Bag
from etsid.progress import progress
from etsid.rosmsgs import typestore


def read(path: Path, options: ReadOptions) -> RawLog:
    """Read a ROS 1 or ROS 2 bag into a :class:`RawLog`.

    Raises
    ------
    IngestError
        Not a readable bag (one line naming the file).
    """
    path = Path(path)
    ros1 = path.is_file() and path.suffix.lower() == ".bag"
    raw = RawLog(path=path, format="ros1" if ros1 else "ros2")
    if ros1:
        _read_ros1(path, options, raw)
    else:
        _read_ros2(path, options, raw)
    return raw


# ---------------------------------------------------------------------------
# rosbags AnyReader


def _errors() -> tuple[type[BaseException], ...]:
    from rosbags.highlevel import AnyReaderError
    from rosbags.rosbag1 import ReaderError as Reader1Error
    from rosbags.rosbag2 import ReaderError as Reader2Error
    from rosbags.serde import SerdeError
    from rosbags.typesys import TypesysError

    return (AnyReaderError, Reader1Error, Reader2Error, SerdeError, TypesysError, KeyError,
            ValueError, struct.error, OSError, EOFError, AssertionError)


def _first_line(err: BaseException) -> str:
    text = " ".join(str(a) for a in err.args) if err.args else type(err).__name__
    return text.strip().splitlines()[0] if text.strip() else type(err).__name__


def _size(path: Path) -> int:
    if path.is_dir():
        return sum(p.stat().st_size for p in path.iterdir() if p.is_file())
    return path.stat().st_size


class _LazyTypestore:
    """The default typestore, built (≈ 3 s: the shipped .msg files) only when a bag lacks
    definitions of its own."""

    def __init__(self, ros1: bool) -> None:
        self.ros1 = ros1

    @property
    def fielddefs(self) -> dict[str, Any]:
        return typestore(ros1=self.ros1).fielddefs


def _slow_one(conv: Converter, broken: dict[str, str], deser: Any, topic: TopicData,
              typename: str, data: bytes, log_ns: int) -> None:
    """Per-message path: deserialise with rosbags, convert one message."""
    if topic.topic in broken:
        conv.count(topic, log_ns)
        return
    try:
        msg = deser(data, typename)
    except _errors() as err:
        broken[topic.topic] = _first_line(err)
        conv.count(topic, log_ns)
        return
    conv.add(topic, msg, log_ns)


def _read_any(paths: list[Path], options: ReadOptions, raw: RawLog, ros1: bool) -> Converter:
    """Stream ``paths`` through AnyReader into a fresh :class:`Converter`."""
    from rosbags.highlevel import AnyReader

    errors = _errors()
    default = _LazyTypestore(ros1)
    conv = Converter(options)
    with AnyReader(paths, default_typestore=default) as reader:
        reader.typestore.register(_missing_types(
            default, reader.typestore, {c.msgtype for c in reader.connections}))
        deser = (reader.typestore.deserialize_ros1 if not reader.is2
                 else reader.typestore.deserialize_cdr)
        fielddefs = reader.typestore.fielddefs
        topics = {c.id: conv.topic(c.topic, c.msgtype) for c in reader.connections}
        broken: dict[str, str] = {}

        def slow(topic: TopicData, typename: Any, data: bytes, log_ns: int) -> None:
            _slow_one(conv, broken, deser, topic, typename, data, log_ns)

        batcher = Batcher(conv, slow)
        done_fast = _read_ros2_fast(reader, paths, options, deser) if reader.is2 else None
        done = 0
        total = sum(_size(p) for p in paths)
        with progress(total, f"reading {paths[0].name}", options.progress) as bar:
            if done_fast is not None:
                conv, broken = done_fast
                bar.update(total)
            try:
                for conn, log_ns, data in (() if done_fast is not None else reader.messages()):
                    topic = topics[conn.id]
                    if not topic.decode or topic.topic in broken:
                        conv.count(topic, log_ns)
                        continue
                    batcher.push(topic, (fielddefs, conn.msgtype, reader.is2), conn.msgtype,
                                 data, log_ns)
                    done += len(data)
                    if done > 1 << 20:
                        bar.update(done)
                        done = 0
            except errors as err:
                raw.warnings.append(f"{raw.path}: reading stopped early ({_first_line(err)}); "
                                    "kept the messages read before that")
            batcher.flush_all()
        _note_broken(conv, broken, raw)
        raw.extra["storage"] = "rosbag1" if not reader.is2 else _storage_name(paths[0])
        raw.extra["message_count"] = sum(c.msgcount for c in reader.connections)
    return conv


def _read_ros2_fast(reader: Any, paths: list[Path], options: ReadOptions,
                    deser: Any) -> tuple[Converter, dict[str, str]] | None:
    """A one-file ROS 2 bag through :mod:`etsid.ingest.ros.fast.ros2`; None when the
    rosbags iteration must be used."""
    storage = fast_ros2.storage_file(paths)
    if not fast.ENABLED or storage is None:
        return None
    if not sum(c.msgcount for c in reader.connections):
        return None
    stream = reader.messages()
    first = next(stream, None)  # rosbags yields nothing when metadata and storage disagree
    stream.close()
    if first is None or first[1] != reader.start_time:
        return None
    conv = Converter(options)
    conv.base_ns = int(reader.start_time)
    broken: dict[str, str] = {}

    def slow(topic: TopicData, typename: str, data: bytes, log_ns: int) -> None:
        _slow_one(conv, broken, deser, topic, typename, data, log_ns)

    try:
        fast_ros2.read(storage, conv, reader.connections, reader.typestore.fielddefs, slow,
                           broken)
    except (fast_ros2.NotFast, fast_mcap.NotFast, OSError):
        return None
    return conv, broken


def _read_ros1_fast(path: Path, options: ReadOptions, raw: RawLog) -> Converter | None:
    """Indexed ROS 1 bag through :class:`Ros1Bag`; None when rosbags must read it."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    if not fast.ENABLED:
        return None
    try:
        bag = Ros1Bag(path)
    except (NotFast, OSError):
        return None
    try:
        first = bag.check_order()
        conv = Converter(options)
        conv.base_ns = None if first is None else int(first)
        store = get_typestore(Stores.EMPTY)
        topics: dict[int, tuple[TopicData, str]] = {}
        for conn in bag.connections.values():
            pkg, _, name = conn.msgtype.partition("/")
            typename = f"{pkg}/msg/{name}"
            topic = conv.topic(conn.topic, typename)
            topics[conn.id] = (topic, typename)
            if topic.decode:
                if not conn.definition:
                    raise NotFast("connection without definition")
                store.register(get_types_from_msg(conn.definition, typename))
        broken: dict[str, str] = {}
        done = 0
        with progress(path.stat().st_size, f"reading {path.name}", options.progress) as bar:
            for conn, log_ns, arr, bodies in bag.messages():
                topic, typename = topics[conn.id]
                if not topic.decode or topic.topic in broken:
                    conv.count_many(topic, log_ns)
                    continue
                if arr is not None and fast.decode_batch(
                        conv, topic, store.fielddefs, typename, arr, log_ns, cdr=False):
                    done += arr.size
                else:
                    datas = bodies if arr is None else [row.tobytes() for row in arr]
                    for data, t in zip(datas, log_ns.tolist(), strict=True):
                        _slow_one(conv, broken, store.deserialize_ros1, topic, typename, data, t)
                        done += len(data)
                if done > 1 << 20:
                    bar.update(done)
                    done = 0
    except (NotFast, OSError, struct.error, KeyError, ValueError, *_errors()):
        return None
    finally:
        bag.close()
    _note_broken(conv, broken, raw)
    raw.extra["storage"] = "rosbag1"
    raw.extra["message_count"] = sum(c.count for c in bag.connections.values())
    return conv


def _missing_types(default: Any, have: Any, names: set[str]) -> dict[str, Any]:
    """Definitions in ``default`` of the ``names`` (and what they use) that ``have`` lacks."""
    from rosbags.typesys.base import Nodetype

    out: dict[str, Any] = {}
    todo = [n for n in names if n not in have.fielddefs]
    while todo:
        name = todo.pop()
        if name in out or name in have.fielddefs or name not in default.fielddefs:
            continue
        out[name] = default.fielddefs[name]
        for _, (kind, detail) in out[name][1]:
            if kind == Nodetype.NAME:
                todo.append(detail)
            elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE) and detail[0][0] == Nodetype.NAME:
                todo.append(detail[0][1])
    return out


def _storage_name(path: Path) -> str:
    if path.is_dir():
        files = [p.suffix for p in path.iterdir()]
        return "mcap" if ".mcap" in files else "sqlite3"
    return "mcap" if path.suffix.lower() == ".mcap" else "sqlite3"


def _note_broken(conv: Converter, broken: dict[str, str], raw: RawLog) -> None:
    for name, why in broken.items():
        topic = conv.topics[name]
        topic.spec, topic.requests = None, []
        topic.note = f"undecodable, skipped ({why})"
        raw.warnings.append(f"{name}: {topic.count} message(s) could not be decoded "
                            f"and were skipped ({why})")


def _read_ros2(path: Path, options: ReadOptions, raw: RawLog) -> None:
    errors = _errors()
    storage = sorted(p for p in path.iterdir() if p.suffix in (".db3", ".mcap")) \
        if path.is_dir() else [path]
    try:
        conv = _read_any([path], options, raw, ros1=False)
        fallback = path.is_dir() and not _decoded_any(conv) and raw.extra["message_count"]
        why = "metadata.yaml disagrees with the storage file (QoS/format): zero messages read"
    except errors as err:
        fallback, conv = path.is_dir(), None
        why = f"metadata.yaml unusable ({_first_line(err)})"
        if not fallback:
            raise IngestError(f"{path}: not a readable ROS 2 bag ({_first_line(err)})") from err
    if fallback:
        if not storage:
            raise IngestError(f"{path}: {why}, and no .db3/.mcap storage file next to it")
        raw.warnings.append(f"{path}: {why}; read {', '.join(p.name for p in storage)} directly")
        try:
            conv = _read_any(storage, options, raw, ros1=False)
        except errors as err:
            raise IngestError(f"{path}: {why}; its storage file is not readable either "
                              f"({_first_line(err)})") from err
    assert conv is not None
    conv.finish(raw)


def _decoded_any(conv: Converter) -> bool:
    return any(t.count for t in conv.topics.values())


def _read_ros1(path: Path, options: ReadOptions, raw: RawLog) -> None:
    from rosbags.rosbag1 import ReaderError as Reader1Error

    errors = _errors()
    try:
        conv = _read_ros1_fast(path, options, raw) or _read_any([path], options, raw, ros1=True)
    except Reader1Error as err:
        text = _first_line(err)
        if "index" not in text.lower():
            raise IngestError(f"{path}: not a readable ROS 1 bag ({text})") from err
        conv = _scan_ros1(path, options, raw)
    except errors as err:
        text = _first_line(err)
        if "index" not in text.lower():
            raise IngestError(f"{path}: not a readable ROS 1 bag ({text})") from err
        conv = _scan_ros1(path, options, raw)
    conv.finish(raw)


# ---------------------------------------------------------------------------
# ROS 1 without index: scan chunks (truncated recordings)

_OP_MSG, _OP_HEADER, _OP_CHUNK, _OP_CONN = 0x02, 0x03, 0x05, 0x07


def _fields(buf: bytes | memoryview) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    pos = 0
    while pos + 4 <= len(buf):
        (size,) = struct.unpack_from("<I", buf, pos)
        name, _, value = bytes(buf[pos + 4:pos + 4 + size]).partition(b"=")
        out[name.decode()] = value
        pos += 4 + size
    return out


def _records(buf: bytes | memoryview, start: int = 0) -> Iterator[tuple[dict[str, bytes],
                                                                        memoryview, int]]:
    """Complete records (header fields, data, end offset) of ``buf`` from ``start``."""
    view = memoryview(buf)
    pos = start
    while pos + 4 <= len(view):
        (hlen,) = struct.unpack_from("<I", view, pos)
        if pos + 8 + hlen > len(view):
            return
        header = _fields(view[pos + 4:pos + 4 + hlen])
        (dlen,) = struct.unpack_from("<I", view, pos + 4 + hlen)
        end = pos + 8 + hlen + dlen
        if end > len(view):
            return
        yield header, view[pos + 8 + hlen:end], end
        pos = end


def _decompress(kind: str, data: bytes | memoryview) -> bytes:
    """As much of a (possibly cut) chunk as can be decompressed."""
    if kind == "none":
        return bytes(data)
    if kind == "bz2":
        return bz2.BZ2Decompressor().decompress(bytes(data))
    if kind == "lz4":
        import lz4.frame

        return lz4.frame.LZ4FrameDecompressor().decompress(bytes(data))
    raise IngestError(f"unknown chunk compression {kind!r}")


def _scan_ros1(path: Path, options: ReadOptions, raw: RawLog) -> Converter:
    """Read a ROS 1 bag without its index, keeping every complete message."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    data = path.read_bytes()
    magic = b"#ROSBAG V2.0\n"
    if not data.startswith(magic):
        raise IngestError(f"{path}: not a ROS 1 bag (bad magic line)")
    conv = Converter(options)
    store = get_typestore(Stores.EMPTY)
    conns: dict[int, tuple[Any, str]] = {}
    used = len(magic)
    cut_chunk = False
    for header, body, end in _records(data, len(magic)):
        op = header.get("op", b"\0")[0]
        if op == _OP_CHUNK:
            kind = header.get("compression", b"none").decode()
            try:
                inner = _decompress(kind, body)
            except (OSError, EOFError, ValueError, RuntimeError) as err:
                raw.warnings.append(f"{path}: chunk at byte {end - len(body)} unreadable ({err})")
                continue
            _scan_chunk(inner, conns, conv, store)
        elif op == _OP_CONN:
            _add_connection(header, body, conns, conv, store, get_types_from_msg)
        used = end
    tail = len(data) - used
    if tail > 0:
        # the last, cut record: try to recover the complete messages inside it
        header_fields = next(iter(_partial_chunk(data, used)), None)
        if header_fields is not None:
            kind, body = header_fields
            try:
                inner = _decompress(kind, body)
            except (OSError, EOFError, ValueError, RuntimeError):
                inner = b""
            kept = _scan_chunk(inner, conns, conv, store)
            cut_chunk = kept > 0
        raw.warnings.append(
            f"{path}: truncated bag (no index): read the chunks before byte {used}"
            + (" and the complete messages of the cut chunk" if cut_chunk else "")
            + f"; {tail} byte(s) at the end could not be read")
    raw.extra["storage"] = "rosbag1 (scanned without index)"
    return conv


def _partial_chunk(data: bytes, pos: int) -> Iterator[tuple[str, memoryview]]:
    view = memoryview(data)
    if pos + 4 > len(view):
        return
    (hlen,) = struct.unpack_from("<I", view, pos)
    if pos + 8 + hlen > len(view):
        return
    header = _fields(view[pos + 4:pos + 4 + hlen])
    if header.get("op", b"\0")[0] == _OP_CHUNK:
        yield header.get("compression", b"none").decode(), view[pos + 8 + hlen:]


def _add_connection(header: dict[str, bytes], body: memoryview, conns: dict[int, Any],
                    conv: Converter, store: Any, parse: Any) -> None:
    cid = struct.unpack("<I", header["conn"])[0]
    if cid in conns:
        return
    info = _fields(body)
    topic = header.get("topic", info.get("topic", b"")).decode()
    msgtype = info.get("type", b"").decode()
    pkg, _, name = msgtype.partition("/")
    typename = f"{pkg}/msg/{name}"
    try:
        store.register(parse(info.get("message_definition", b"").decode(), typename))
    except Exception:  # a bad definition only disables this topic
        conv.topic(topic, typename).spec = None
    conns[cid] = (conv.topic(topic, typename), typename)


def _scan_chunk(buf: bytes, conns: dict[int, Any], conv: Converter, store: Any) -> int:
    from rosbags.typesys import get_types_from_msg

    kept = 0
    for header, body, _ in _records(buf):
        op = header.get("op", b"\0")[0]
        if op == _OP_CONN:
            _add_connection(header, body, conns, conv, store, get_types_from_msg)
        elif op == _OP_MSG:
            cid = struct.unpack("<I", header["conn"])[0]
            if cid not in conns:
                continue
            topic, typename = conns[cid]
            sec, nsec = struct.unpack("<II", header["time"])
            log_ns = sec * 1_000_000_000 + nsec
            if not topic.decode:
                conv.count(topic, log_ns)
                continue
            try:
                msg = store.deserialize_ros1(bytes(body), typename)
            except Exception:  # a bad definition only disables this topic
                conv.count(topic, log_ns)
                continue
            conv.add(topic, msg, log_ns)
            kept += 1
    return kept
