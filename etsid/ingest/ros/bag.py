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
* a ROS 1 bag cut off before its index (truncated), with a damaged index, or giving fewer
  messages than its index lists is scanned record by record
  (:mod:`etsid.ingest.ros.ros1_scan`): every message that decodes is kept, before and
  after damage, and the notes say the seconds missing;
* a one-file ROS 2 bag from which rosbags reads fewer messages than metadata.yaml lists
  (or none) is read from its storage file by etsid's salvage readers, and the read that
  keeps more messages wins;
* a message that cannot be decoded is skipped and counted (topic, count, time range);
  the other messages of its topic are kept.
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

from etsid.errors import IngestError
from etsid.files import check, read_text
from etsid.ingest.base import RawLog, ReadOptions
from etsid.ingest.damage import decoder_errors, gap_note
from etsid.ingest.ros import bounded, ros1_scan
from etsid.ingest.ros.converter import Converter, TopicData
from etsid.ingest.ros.fast import decode as fast
from etsid.ingest.ros.fast import mcap as fast_mcap
from etsid.ingest.ros.fast import ros2 as fast_ros2
from etsid.ingest.ros.fast.decode import Batcher
from etsid.ingest.ros.fast.ros1 import LostChunk, NotFast, Ros1Bag
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
    return decoder_errors()


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


def _slow_one(conv: Converter, deser: Any, topic: TopicData, typename: str, data: bytes,
              log_ns: int) -> None:
    """Per-message path: deserialise with rosbags, convert one message (one that does not
    decode is skipped and counted, never its topic)."""
    try:
        msg = deser(data, typename)
    except _errors() as err:
        conv.undecodable(topic, log_ns, err)
        return
    conv.add(topic, msg, log_ns)


def _fails_alike(deser: Any, arr: Any, typename: str) -> BaseException | None:
    """What decoding raises when every message of ``arr`` (messages, bytes) holds the same
    bytes and they do not decode (a flood of one bad message: decoded once); else None."""
    if len(arr) < 2 or not (arr == arr[0]).all():
        return None
    try:
        deser(arr[0].tobytes(), typename)
    except _errors() as err:
        return err
    return None


def _read_any(paths: list[Path], options: ReadOptions, raw: RawLog, ros1: bool) -> Converter:
    """Stream ``paths`` through AnyReader into a fresh :class:`Converter`."""
    from rosbags.highlevel import AnyReader

    errors = _errors()
    default = _LazyTypestore(ros1)
    conv = Converter(options)
    bounded.install()  # rosbags' MCAP chunks decompress within etsid's bound
    for item in paths:  # rosbags opens them itself: regular files only
        if item.is_dir():
            for part in item.iterdir():
                check(part, "log", IngestError)
        else:
            check(item, "log", IngestError)
    with AnyReader(paths, default_typestore=default) as reader:
        reader.typestore.register(_missing_types(
            default, reader.typestore, {c.msgtype for c in reader.connections}))
        deser = (reader.typestore.deserialize_ros1 if not reader.is2
                 else reader.typestore.deserialize_cdr)
        fielddefs = reader.typestore.fielddefs
        topics = {c.id: conv.topic(c.topic, c.msgtype) for c in reader.connections}

        def slow(topic: TopicData, typename: Any, data: bytes, log_ns: int) -> None:
            _slow_one(conv, deser, topic, typename, data, log_ns)

        batcher = Batcher(conv, slow)
        done_fast = _read_ros2_fast(reader, paths, options, deser) if reader.is2 else None
        done = 0
        total = sum(_size(p) for p in paths)
        with progress(total, f"reading {paths[0].name}", options.progress) as bar:
            if done_fast is not None:
                conv = done_fast
                bar.update(total)
            try:
                for conn, log_ns, data in (() if done_fast is not None else reader.messages()):
                    topic = topics[conn.id]
                    if not topic.decode:
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
        raw.extra["storage"] = "rosbag1" if not reader.is2 else _storage_name(paths[0])
        raw.extra["message_count"] = sum(c.msgcount for c in reader.connections)
    return conv


def _read_ros2_fast(reader: Any, paths: list[Path], options: ReadOptions,
                    deser: Any) -> Converter | None:
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

    def slow(topic: TopicData, typename: str, data: bytes, log_ns: int) -> None:
        _slow_one(conv, deser, topic, typename, data, log_ns)

    try:
        fast_ros2.read(storage, conv, reader.connections, reader.typestore.fielddefs, slow,
                       lambda arr, typename: _fails_alike(deser, arr, typename))
    except (fast_ros2.NotFast, fast_mcap.NotFast, OSError):
        return None
    return conv


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
        done = 0
        with progress(path.stat().st_size, f"reading {path.name}", options.progress) as bar:
            for conn, log_ns, arr, bodies in bag.messages():
                topic, typename = topics[conn.id]
                if not topic.decode:
                    conv.count_many(topic, log_ns)
                    continue
                if arr is not None and fast.decode_batch(
                        conv, topic, store.fielddefs, typename, arr, log_ns, cdr=False):
                    done += arr.size
                elif arr is not None and (err := _fails_alike(store.deserialize_ros1, arr,
                                                              typename)) is not None:
                    conv.undecodable_many(topic, log_ns, err)
                else:
                    datas = bodies if arr is None else [row.tobytes() for row in arr]
                    for data, t in zip(datas, log_ns.tolist(), strict=True):
                        _slow_one(conv, store.deserialize_ros1, topic, typename, data, t)
                        done += len(data)
                if done > 1 << 20:
                    bar.update(done)
                    done = 0
    except (NotFast, OSError, struct.error, KeyError, ValueError, *_errors()):
        return None
    finally:
        bag.close()
    _note_lost(bag.lost, conv, raw)
    raw.extra["storage"] = "rosbag1"
    raw.extra["message_count"] = sum(c.count for c in bag.connections.values())
    return conv


def _note_lost(lost: list[LostChunk], conv: Converter, raw: RawLog) -> None:
    """One coverage note for the damaged chunks the fast reader skipped."""
    if not lost:
        return
    base = conv.base_ns
    spans = [((c.start_ns - base) * 1e-9, (c.end_ns - base) * 1e-9) for c in lost
             if base is not None and c.end_ns >= c.start_ns > 0]
    spans = [(a, b) for a, b in spans if -1e6 < a <= b < 1e6]
    what = (f"skipped {len(lost)} damaged chunk(s) at byte "
            f"{', '.join(str(c.pos) for c in lost[:5])}{' …' if len(lost) > 5 else ''} "
            f"({lost[0].why}): {sum(c.messages for c in lost)} message(s) lost")
    raw.warnings.append(gap_note(raw.path, what, spans))


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
            try:
                _salvage(path, options, raw)
            except IngestError:
                raise IngestError(f"{path}: not a readable ROS 2 bag ({_first_line(err)})"
                                  ) from err
            raw.warnings.insert(0, f"{path}: damaged storage file ({_first_line(err)}); "
                                "kept what can be read")
            return
        if _metadata_loads(path):
            why = f"storage file damaged ({_first_line(err)})"
    if fallback:
        if not storage:
            raise IngestError(f"{path}: {why}, and no .db3/.mcap storage file next to it")
        raw.warnings.append(f"{path}: {why}; read {', '.join(p.name for p in storage)} directly")
        try:
            conv = _read_any(storage, options, raw, ros1=False)
        except errors as err:
            if len(storage) != 1:
                raise IngestError(f"{path}: {why}; its storage files are not readable either "
                                  f"({_first_line(err)})") from err
            try:
                _salvage(storage[0], options, raw, _metadata_seconds(path))
            except IngestError as salvage_err:
                raise IngestError(f"{path}: {why}; its storage file is not readable either "
                                  f"({salvage_err})") from err
            return
    assert conv is not None
    kept = sum(t.count for t in conv.topics.values())
    short = kept < int(raw.extra.get("message_count") or 0)  # fewer than metadata.yaml says
    if len(storage) == 1 and (short or any("reading stopped early" in w
                                           for w in raw.warnings)):
        trial = RawLog(path=raw.path, format=raw.format)
        try:
            _salvage(storage[0], options, trial, _metadata_seconds(path))
        except IngestError:
            trial = None
        if trial is not None and int(trial.extra.get("message_count", 0)) > kept:
            early = [w for w in raw.warnings if "reading stopped early" in w]
            raw.warnings[:] = [w for w in raw.warnings if w not in early]
            for name in ("channels", "signals", "start_time", "dropped", "repaired", "extra"):
                setattr(raw, name, getattr(trial, name))
            head = early[0].split("; ")[0] if early else \
                f"{raw.path}: rosbags read {kept} of the messages metadata.yaml lists"
            raw.warnings.append(f"{head}; read on past the damage")
            raw.warnings.extend(trial.warnings)
            return
    conv.finish(raw)


def _metadata_loads(path: Path) -> bool:
    """True when the bag's metadata.yaml is valid YAML naming storage files that exist."""
    import yaml

    try:
        data = yaml.safe_load(read_text(path / "metadata.yaml", "bag-metadata", IngestError))
    except (IngestError, ValueError, yaml.YAMLError):
        return False
    info = data.get("rosbag2_bagfile_information") if isinstance(data, dict) else None
    files = info.get("relative_file_paths") if isinstance(info, dict) else None
    return isinstance(files, list) and bool(files) and all(
        isinstance(f, str) and (path / f).is_file() for f in files)


def _metadata_seconds(path: Path) -> float | None:
    """The recording's length (s) that a bag's metadata.yaml states, or None."""
    import yaml

    if not path.is_dir():
        return None
    try:
        data = yaml.safe_load(read_text(path / "metadata.yaml", "bag-metadata", IngestError))
        ns = data["rosbag2_bagfile_information"]["duration"]["nanoseconds"]
        seconds = float(ns) * 1e-9
    except (OSError, ValueError, TypeError, KeyError, yaml.YAMLError):
        return None
    return seconds if 0 < seconds < 1e7 else None


def _salvage(storage: Path, options: ReadOptions, raw: RawLog,
             total_s: float | None = None) -> None:
    """Read what a damaged storage file still holds (:mod:`etsid.ingest.ros.salvage`);
    ``total_s``: the recording's length per metadata.yaml, for the note on a cut file."""
    from etsid.ingest.ros import salvage

    if storage.suffix == ".mcap":
        salvage.read_mcap(storage, options, raw, total_s)
        return
    conv = salvage.read_db3(storage, options, raw)
    conv.finish(raw)


def _decoded_any(conv: Converter) -> bool:
    return any(t.count for t in conv.topics.values())


def _read_ros1(path: Path, options: ReadOptions, raw: RawLog) -> None:
    """Through the index (fast reader, else rosbags); a bag whose index is missing or
    damaged, or that gives fewer messages than its index lists, is scanned chunk by chunk
    (:mod:`etsid.ingest.ros.ros1_scan`) and the scan kept when it reads more."""
    conv: Converter | None = None
    failure = ""
    before = list(raw.warnings)
    try:
        conv = _read_ros1_fast(path, options, raw) or _read_any([path], options, raw, ros1=True)
    except _errors() as err:
        failure = _first_line(err)
    kept = 0 if conv is None else sum(t.count for t in conv.topics.values())
    listed = int(raw.extra.get("message_count") or 0) if conv is not None else 0
    stopped = any("reading stopped early" in w for w in raw.warnings)
    if conv is None or not kept or kept < listed or stopped:
        trial = RawLog(path=raw.path, format=raw.format)
        try:
            scanned = ros1_scan.scan(path, options, trial)
        except IngestError as err:
            if conv is None:
                raise IngestError(f"{path}: not a readable ROS 1 bag ({failure}; {err})"
                                  ) from err
            scanned = None
        if conv is None and scanned is not None and not any(
                t.count for t in scanned.topics.values()):
            raise IngestError(f"{path}: not a readable ROS 1 bag ({failure}; no message "
                              "found by scanning its chunks either)")
        if scanned is not None and (conv is None or
                                    sum(t.count for t in scanned.topics.values()) > kept):
            why = failure or (f"its index lists {listed} messages, {kept} read through it"
                              if listed else "no message read through its index")
            raw.warnings[:] = before  # the notes of the index read no longer apply
            raw.warnings.append(f"{path}: index unusable ({why}); scanned the chunks")
            raw.warnings.extend(trial.warnings)
            raw.extra.update(trial.extra)
            conv = scanned
    assert conv is not None
    conv.finish(raw)
