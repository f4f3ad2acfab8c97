"""MCAP files (``.mcap``): ros1, ros2 (cdr) and json message encodings.

One sequential pass (memory bounded by the output): complete files with the numpy record
walker of :mod:`etsid.ingest.ros.fast.mcap` and batch decoding of
:mod:`etsid.ingest.ros.fast.decode`; files cut short (summary missing) or damaged with
:class:`mcap.stream_reader.StreamReader`. Messages are decoded per
channel: ``cdr`` (ROS 2) and ``ros1`` with rosbags' generated deserializers built from the
channel's schema (5-10x faster than the pure-Python mcap decoders, and the very code the
bag reader uses), falling back to mcap-ros2-support's / mcap-ros1-support's decoder
factories when rosbags cannot parse a schema; ``json`` with :func:`json.loads`. Only
channels whose type maps to FlightTable columns (or that a ``--map`` field asks for) are
decoded; the conversion is
:mod:`etsid.ingest.ros.messages` (the same as for bags, so a ROS 2 bag's ``.mcap``
storage file gives the same signals as its bag directory). JSON messages use the field
names of the ROS message they stand for; MAVLink messages as JSON (schema name
``mavlink.ATTITUDE`` …) are understood too.

A channel that cannot be decoded (unknown encoding, broken schema) does not abort the
file: it is skipped, counted, and named in the warnings and its channel note. A message
whose bytes do not decode is skipped alone and counted (topic, count, time range).
Service-event channels are listed, not decoded.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from etsid.errors import IngestError
from etsid.files import open_binary
from etsid.ingest.base import RawLog, ReadOptions
from etsid.ingest.damage import cut_note, describe, gap_note
from etsid.ingest.ros.converter import Converter, TopicData
from etsid.ingest.ros.fast import decode as fast
from etsid.ingest.ros.fast import mcap as fast_mcap
from etsid.ingest.ros.fast import mcap_resync
from etsid.ingest.ros.fast.decode import Batcher
from etsid.ingest.ros.messages import as_message
from etsid.progress import progress


def _json_decoder(data: bytes) -> Any:
    return as_message(json.loads(data))


class _Decoders:
    """Decoders per channel: rosbags' generated deserializers for ``ros2msg``/``ros1msg``
    schemas (fast, and the same code as the bag reader), else the mcap decoder factories."""

    def __init__(self) -> None:
        from rosbags.typesys import Stores, get_typestore

        self.factories: list[Any] | None = None
        """The mcap decoder factories (ROS 2, ROS 1), made at the first schema rosbags
        cannot parse (importing them costs ~0.1 s of a small file's inspect)."""
        self.store = get_typestore(Stores.EMPTY)
        self.made: dict[tuple[str, Any], Callable[[bytes], Any]] = {}
        """Decoders made, per message encoding and schema (many channels share one)."""

    def fast_info(self, decoder: Callable[[bytes], Any]) -> tuple[dict[str, Any], str, bool] | None:
        """(fielddefs, typename, cdr) for the vectorised path when ``decoder`` is rosbags'."""
        info = getattr(decoder, "rosbags", None)
        return None if info is None else (self.store.fielddefs, info[0], info[1])

    def _rosbags(self, encoding: str, schema: Any) -> Callable[[bytes], Any] | None:
        from rosbags.typesys import get_types_from_msg

        kinds = {("cdr", "ros2msg"): "deserialize_cdr", ("ros1", "ros1msg"): "deserialize_ros1"}
        method = kinds.get((encoding, schema.encoding if schema is not None else ""))
        if method is None:
            return None
        pkg, _, name = schema.name.replace("/msg/", "/").partition("/")
        typename = f"{pkg}/msg/{name}"
        try:
            self.store.register(get_types_from_msg(schema.data.decode(), typename))
            self.store.get_msgdef(typename)
        except Exception:  # unparsable or conflicting definition: use the mcap decoders
            return None
        deserialize = getattr(self.store, method)

        def decode(data: bytes) -> Any:
            return deserialize(data, typename)

        decode.rosbags = (typename, encoding == "cdr")  # type: ignore[attr-defined]
        return decode

    def make(self, encoding: str, schema: Any) -> Callable[[bytes], Any]:
        """A decoder for ``encoding`` and ``schema``; raises ValueError when there is none."""
        if encoding == "json":
            return _json_decoder
        key = (encoding, None if schema is None else (schema.name, schema.encoding,
                                                      bytes(schema.data)))
        if key not in self.made:
            self.made[key] = self._make(encoding, schema)
        return self.made[key]

    def _make(self, encoding: str, schema: Any) -> Callable[[bytes], Any]:
        decoder = self._rosbags(encoding, schema)
        if decoder is not None:
            return decoder
        if self.factories is None:
            from mcap_ros1.decoder import DecoderFactory as Ros1Factory
            from mcap_ros2.decoder import DecoderFactory as Ros2Factory

            self.factories = [Ros2Factory(), Ros1Factory()]
        for factory in self.factories:
            decoder = factory.decoder_for(encoding, schema)
            if decoder is not None:
                return decoder
        kind = f"schema encoding {schema.encoding!r}" if schema is not None else "no schema"
        raise ValueError(f"no decoder for message encoding {encoding!r} with {kind}")


def read(path: Path, options: ReadOptions, total_s: float | None = None) -> RawLog:
    """Read an MCAP file into a :class:`RawLog`.

    ``total_s``: the recording's length when known from elsewhere (a ROS 2 bag's
    metadata.yaml), for the note on a cut file.

    Raises
    ------
    IngestError
        Not a readable MCAP file, or one without any complete message.
    """
    path = Path(path)
    if fast.ENABLED:
        raw = RawLog(path=path, format="mcap")
        state = _State(options, raw)
        try:
            for record in fast_mcap.records(path):
                state.record(record)
        except fast_mcap.NotFast:
            pass
        else:
            return state.finish()
    elif (raw := _read_stream(path, options)) is not None:
        return raw
    raw = RawLog(path=path, format="mcap")
    state = _State(options, raw, total_s)
    size = path.stat().st_size
    with progress(size, f"reading {path.name}", options.progress) as bar:
        try:
            for record in mcap_resync.scan(path):
                state.record(record)
        except (OSError, ValueError) as err:
            raise IngestError(f"{path}: not a readable MCAP file ({describe(err)})") from err
        bar.update(size)
    if state.messages == 0 and state.cut is not None:
        raise IngestError(f"{path}: truncated MCAP file: no complete message before byte "
                          f"{state.cut.pos} of {size}")
    if state.messages == 0:
        raise IngestError(f"{path}: not a readable MCAP file: no complete message")
    return state.finish()


def _read_stream(path: Path, options: ReadOptions) -> RawLog | None:
    """A whole file through :class:`mcap.stream_reader.StreamReader` (the reference path,
    ``ETSID_ROS_FAST=0``); None when it meets damage (the resync scan reads it then)."""
    from mcap.records import Channel, Header, Message, Schema
    from mcap.stream_reader import StreamReader

    raw = RawLog(path=path, format="mcap")
    state = _State(options, raw)
    with open_binary(path, "log", IngestError) as handle:
        try:
            for record in StreamReader(handle).records:
                if isinstance(record, Message):
                    state.message(record)
                elif isinstance(record, (Schema, Channel, Header)):
                    state.record(record)
        except Exception:
            return None
    return state.finish()


class _State:
    """Channels, decoders and the converter of one read (stream reader or numpy walk)."""

    def __init__(self, options: ReadOptions, raw: RawLog, total_s: float | None = None) -> None:
        self.raw = raw
        self.total_s = total_s
        self.conv = Converter(options)
        self.decoders = _Decoders()
        self.broken: dict[str, str] = {}
        self.batcher = Batcher(self.conv, lambda topic, state, data, log_ns: _slow(
            self.conv, topic, state, data, log_ns, self.broken))
        self.schemas: dict[int, Any] = {}
        self.channels: dict[int, tuple[TopicData, Any]] = {}
        self.known = np.zeros(1 << 16, dtype=bool)  # channel ids are uint16: one lookup
        self.encodings: set[str] = set()
        self.messages = 0
        self.lost: list[mcap_resync.Lost] = []
        self.gaps_ns: list[tuple[int, int]] = []  # log times around each damage
        self.waiting: list[mcap_resync.Lost] = []  # damage not yet followed by a message
        self.first_ns: int | None = None
        self.last_ns: int | None = None
        self.cut: mcap_resync.Cut | None = None
        self.spare: tuple[dict[int, Any], dict[int, Any]] | None = None
        """Schemas and channels of the summary section, read when a message's channel is
        unknown (:meth:`_from_summary`)."""

    def _times(self, lo: int, hi: int) -> None:
        """Log times of the next messages kept: close the gaps waiting for them."""
        if self.waiting:  # one gap, however many stretches were skipped in a row
            before = self.last_ns if self.last_ns is not None else self.waiting[0].start_ns
            if before is not None:
                self.gaps_ns.append((before, lo))
            self.waiting = []
        self.first_ns = lo if self.first_ns is None else min(self.first_ns, lo)
        self.last_ns = hi if self.last_ns is None else max(self.last_ns, hi)

    def record(self, record: Any) -> None:
        """Take a Schema, Channel or Header record, or a run of messages (numpy walk)."""
        from mcap.records import Channel, Header, Schema

        if isinstance(record, fast_mcap.Messages):
            self.run(record)
        elif isinstance(record, mcap_resync.Lost):
            self.lost.append(record)
            self.waiting.append(record)
        elif isinstance(record, mcap_resync.Cut):
            self.cut = record
        elif isinstance(record, Schema):
            self.schemas[record.id] = record
        elif isinstance(record, Channel):
            if record.id not in self.channels:
                self.channels[record.id] = _open_channel(self.conv, record, self.schemas)
                self.known[record.id] = True
                self.encodings.add(record.message_encoding)
        elif isinstance(record, Header):
            self.raw.extra["profile"] = record.profile
            self.raw.extra["library"] = record.library

    def message(self, record: Any) -> None:
        """Take one Message record (stream reader)."""
        self.messages += 1
        self._times(record.log_time, record.log_time)
        entry = self.channels.get(record.channel_id)
        if entry is not None:
            _take(self.conv, self.batcher, entry, record.log_time, record.data, self.decoders,
                  self.broken)

    def run(self, run: fast_mcap.Messages) -> None:
        """Take a run of messages at once: vectorised per channel where possible."""
        self.messages += len(run.channel)
        if len(run.log_ns):
            self._times(int(run.log_ns.min()), int(run.log_ns.max()))
        known = self.known[run.channel]
        if not known.all():
            self._from_summary(np.unique(run.channel[~known]).tolist())
            known = self.known[run.channel]
        if not known.any():
            return
        if self.conv.base_ns is None:
            self.conv.base_ns = int(run.log_ns[np.argmax(known)])
        for cid in np.unique(run.channel[known]).tolist():
            topic, state = self.channels[cid]
            mask = run.channel == cid
            logs = run.log_ns[mask]
            if not topic.decode or topic.topic in self.broken:
                self.conv.count_many(topic, logs)
                continue
            if state[2] is None:
                _take(self.conv, self.batcher, (topic, state), int(logs[0]), None,
                      self.decoders, self.broken, make_only=True)
                if topic.topic in self.broken:
                    self.conv.count_many(topic, logs[1:])
                    continue
            arr, bodies = run.bodies(mask)
            if arr is not None and state[3] is not None and fast.fast_kind(topic):
                self.batcher.flush(topic.topic)
                if fast.decode_batch(self.conv, topic, state[3][0], state[3][1], arr, logs,
                                         state[3][2]):
                    continue
            if arr is not None and len(arr) > 1 and (arr == arr[0]).all():
                try:  # identical bytes (a flood of one message): decoded once
                    state[2](arr[0].tobytes())
                except Exception as err:
                    self.batcher.flush(topic.topic)
                    self.conv.undecodable_many(topic, logs, err)
                    continue
            if arr is not None:
                bodies = [row.tobytes() for row in arr]
            for data, log_ns in zip(bodies, logs.tolist(), strict=True):
                _take(self.conv, self.batcher, (topic, state), log_ns, data, self.decoders,
                      self.broken)

    def _from_summary(self, ids: list[int]) -> None:
        """Open the channels ``ids`` from the summary section's copies (their own Channel
        record was in a lost chunk); read once, on the first message of an unknown id."""
        if self.spare is None:
            self.spare = fast_mcap.summary_channels(self.raw.path)
        schemas, channels = self.spare
        for cid in ids:
            channel = channels.get(cid)
            if channel is None:
                continue
            if channel.schema_id not in self.schemas and channel.schema_id in schemas:
                self.schemas[channel.schema_id] = schemas[channel.schema_id]
            self.record(channel)

    def finish(self) -> RawLog:
        """Convert what is queued and fill the raw log."""
        self.batcher.flush_all()
        for name, why in self.broken.items():
            topic = self.conv.topics[name]
            topic.note = f"undecodable, skipped ({why})"
            self.raw.warnings.append(f"{name}: {topic.count} message(s) could not be decoded "
                                     f"and were skipped ({why})")
        self.raw.extra["encodings"] = sorted(self.encodings)
        self._note_lost()
        self.conv.finish(self.raw)
        return self.raw

    def _note_lost(self) -> None:
        """Coverage notes: the damaged stretches skipped (in seconds) and a cut end."""
        base = self.conv.base_ns if self.conv.base_ns is not None else self.first_ns

        def sec(ns: int | None) -> float | None:
            return None if ns is None or base is None else (ns - base) * 1e-9

        first, last = sec(self.first_ns), sec(self.last_ns)
        if self.lost:
            gaps = [(sec(a), sec(b)) for a, b in self.gaps_ns]
            for lost in self.waiting:  # damage after the last message kept
                if lost.end_ns is not None and self.last_ns is not None \
                        and lost.end_ns > self.last_ns:
                    gaps.append((last, sec(lost.end_ns)))
            spans = [(a, b) for a, b in gaps
                     if a is not None and b is not None and -1e6 < a <= b < 1e6]
            where = ", ".join(str(c.pos) for c in self.lost[:5])
            what = (f"skipped {len(self.lost)} damaged stretch(es) at byte {where}"
                    f"{' …' if len(self.lost) > 5 else ''} "
                    f"({sum(c.nbytes for c in self.lost)} bytes; {self.lost[0].why}); "
                    f"kept {self.messages} message(s) before and after")
            self.raw.warnings.append(gap_note(self.raw.path, what, spans, first, last))
        if self.cut is not None:
            what = (f"truncated: the file ends ({self.cut.size} bytes) inside the record "
                    f"at byte {self.cut.pos}")
            self.raw.warnings.append(cut_note(self.raw.path, what, self.messages, first, last,
                                              self.total_s))


def _open_channel(conv: Converter, record: Any, schemas: dict[int, Any]) -> tuple[TopicData, Any]:
    schema = schemas.get(record.schema_id)
    msgtype = schema.name if schema is not None else "(no schema)"
    topic = conv.topic(record.topic, msgtype)
    return topic, [record.message_encoding, schema, None, None]


def _take(conv: Converter, batcher: Batcher, entry: tuple[TopicData, Any], log_ns: int,
          data: bytes | None, decoders: _Decoders, broken: dict[str, str],
          make_only: bool = False) -> None:
    """Queue one message (``make_only``: only make the channel's decoder, or break it)."""
    topic, state = entry
    if not topic.decode or topic.topic in broken:
        if not make_only:
            conv.count(topic, log_ns)
        return
    if state[2] is None:
        try:
            state[2] = decoders.make(state[0], state[1])
        except Exception as err:  # no decoder: this channel only is skipped
            _broken(conv, topic, broken, err, log_ns)
            return
        state[3] = decoders.fast_info(state[2])
    if not make_only:
        batcher.push(topic, state[3], state, data, log_ns)


def _broken(conv: Converter, topic: TopicData, broken: dict[str, str], err: Exception,
            log_ns: int) -> None:
    text = " ".join(str(a) for a in err.args) or type(err).__name__
    broken[topic.topic] = f"{type(err).__name__}: {text.splitlines()[0][:120]}"
    topic.spec, topic.requests = None, []
    conv.count(topic, log_ns)


def _slow(conv: Converter, topic: TopicData, state: Any, data: bytes, log_ns: int,
          broken: dict[str, str]) -> None:
    """Per-message path: decode one message and convert it (one that does not decode is
    skipped and counted, never its channel)."""
    if topic.topic in broken:
        conv.count(topic, log_ns)
        return
    try:
        msg = state[2](data)
    except Exception as err:  # any decoder failure on these bytes: this message only
        conv.undecodable(topic, log_ns, err)
        return
    conv.add(topic, msg, log_ns)
