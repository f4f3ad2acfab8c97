"""ROS 2 bags with one storage file, read around rosbags' per-message iteration.

rosbags (opened first: connections, type definitions, start time) yields one message at a
time in time order across topics (≈ 150 k msg/s before any decoding). Here the storage file
is read in storage order, a batch at a time (sqlite3: one scan of the messages table; mcap:
:mod:`etsid.ingest.ros.fast.mcap`) and split per topic, and each batch goes to
:func:`etsid.ingest.ros.fast.decode.decode_batch` or, message by message, to the slow path.

The result equals rosbags' order only when every topic's record times strictly increase
and the bag's start time is the smallest record time; both are verified while reading, and
:class:`NotFast` is raised otherwise (the caller then starts again with rosbags).
"""

from __future__ import annotations

import sqlite3
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from etsid.ingest.ros.converter import Converter, TopicData
from etsid.ingest.ros.fast import decode as fast
from etsid.ingest.ros.fast import mcap as fast_mcap

Slow = Callable[[TopicData, str, bytes, int], None]
Alike = Callable[[np.ndarray, str], BaseException | None]


class NotFast(Exception):
    """The bag needs rosbags' general reader."""


def storage_file(paths: list[Path]) -> Path | None:
    """The single ``.db3``/``.mcap`` storage file of a bag (directory or file), else None."""
    if len(paths) != 1:
        return None
    path = paths[0]
    if path.is_dir():
        files = [p for p in path.iterdir() if p.suffix in (".db3", ".mcap")]
        return files[0] if len(files) == 1 else None
    return path if path.suffix in (".db3", ".mcap") else None


class _Order:
    """Checks per-topic strictly increasing record times and the global first time."""

    def __init__(self, base_ns: int) -> None:
        self.base_ns = base_ns
        self.first: int | None = None
        self.last: dict[str, int] = {}

    def check(self, name: str, log_ns: np.ndarray) -> None:
        if not len(log_ns):
            return
        prev = self.last.get(name)
        if (prev is not None and log_ns[0] <= prev) or (np.diff(log_ns) <= 0).any():
            raise NotFast("record times not strictly increasing")
        self.last[name] = int(log_ns[-1])
        low = int(log_ns[0])
        self.first = low if self.first is None else min(self.first, low)
        if low < self.base_ns:
            raise NotFast("message before the bag's start time")

    def done(self) -> None:
        if self.first is not None and self.first != self.base_ns:
            raise NotFast("bag start time is not the first record time")


def _take(conv: Converter, topic: TopicData, typename: str, fielddefs: dict[str, Any],
          arr: np.ndarray | None, bodies: list[bytes], log_ns: np.ndarray, slow: Slow,
          alike: Alike | None) -> None:
    if not topic.decode:
        conv.count_many(topic, log_ns)
        return
    if arr is not None and fast.decode_batch(conv, topic, fielddefs, typename, arr,
                                                 log_ns, cdr=True):
        return
    if arr is not None and alike is not None and (err := alike(arr, typename)) is not None:
        conv.undecodable_many(topic, log_ns, err)  # one bad message, many times
        return
    if arr is not None:
        bodies = [row.tobytes() for row in arr]
    for data, t in zip(bodies, log_ns.tolist(), strict=True):
        slow(topic, typename, data, t)


def read(storage: Path, conv: Converter, connections: list[Any], fielddefs: dict[str, Any],
         slow: Slow, alike: Alike | None = None) -> None:
    """Convert every message of ``storage`` into ``conv`` (whose ``base_ns`` is set).

    ``alike(arr, typename)``: what decoding raises when every message of a batch holds
    the same bytes and they do not decode (else None): such a batch is counted at once.

    Raises
    ------
    NotFast
        The per-topic order could differ from rosbags' (nothing usable was converted).
    """
    by_topic = {c.topic: c for c in connections}
    if len(by_topic) != len(connections) or conv.base_ns is None:
        raise NotFast("topics not unique")
    order = _Order(conv.base_ns)
    topics = {c.topic: conv.topic(c.topic, c.msgtype) for c in connections}
    decode = {name for name, topic in topics.items() if topic.decode}
    counts = dict.fromkeys(topics, 0)
    reader = _sqlite if storage.suffix == ".db3" else _mcap
    for name, arr, bodies, log_ns in reader(storage, by_topic, decode):
        order.check(name, log_ns)
        counts[name] += len(log_ns)
        _take(conv, topics[name], by_topic[name].msgtype, fielddefs, arr, bodies, log_ns,
              slow, alike)
    order.done()
    if any(counts[c.topic] != c.msgcount for c in connections):
        raise NotFast("storage and metadata disagree on message counts")


Batch = tuple[str, np.ndarray | None, list[bytes], np.ndarray]


def _sqlite(path: Path, by_topic: dict[str, Any], decode: set[str]) -> Iterator[Batch]:
    """One scan of the messages table in storage (rowid) order, batch by batch; the bodies
    of topics that are not decoded are not fetched."""
    # immutable: no locking and no -shm/-wal files next to the bag (it may be read-only);
    # a pending WAL is then not seen, the count check sends such bags to rosbags
    db = sqlite3.connect(f"{path.resolve().as_uri()}?immutable=1", uri=True)
    try:
        ids = dict(db.execute("SELECT id, name FROM topics").fetchall())
        if sorted(ids.values()) != sorted(by_topic):
            raise NotFast("storage topics differ from the metadata")
        wanted = ",".join(str(int(i)) for i, name in ids.items() if name in decode) or "-1"
        cur = db.execute("SELECT topic_id, timestamp, CASE WHEN topic_id IN "
                         f"({wanted}) THEN data END FROM messages")
        while rows := cur.fetchmany(fast.BATCH):
            tids, logs, datas = zip(*rows, strict=True)
            tid = np.array(tids, dtype=np.int64)
            log_ns = np.array(logs, dtype=np.int64)
            for one in np.unique(tid).tolist():
                if one not in ids:
                    raise NotFast("message of an unknown topic")
                idx = np.flatnonzero(tid == one)
                name = ids[one]
                if name not in decode:
                    yield name, None, [], log_ns[idx]
                    continue
                bodies = [datas[i] for i in idx.tolist()]
                arr = fast.same_length(bodies)
                yield name, arr, ([] if arr is not None else bodies), log_ns[idx]
    except sqlite3.Error as err:
        raise NotFast(str(err)) from err
    finally:
        db.close()


def _mcap(path: Path, by_topic: dict[str, Any], decode: set[str]) -> Iterator[Batch]:
    from mcap.records import Channel

    names: dict[int, str] = {}
    for record in fast_mcap.records(path):
        if isinstance(record, Channel):
            if record.topic not in by_topic:
                raise NotFast("storage topics differ from the metadata")
            names[record.id] = record.topic
        elif isinstance(record, fast_mcap.Messages):
            for cid in np.unique(record.channel).tolist():
                if cid not in names:
                    raise NotFast("message on an unknown channel")
                mask = record.channel == cid
                if names[cid] not in decode:
                    yield names[cid], None, [], record.log_ns[mask]
                    continue
                arr, bodies = record.bodies(mask)
                yield names[cid], arr, bodies, record.log_ns[mask]
