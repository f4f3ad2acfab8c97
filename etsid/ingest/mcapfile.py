"""MCAP files (``.mcap``): ros1, ros2 (cdr) and json message encodings.

One sequential pass with :class:`mcap.stream_reader.StreamReader` (memory bounded by the
output; works on files cut short, whose summary is missing). Messages are decoded per
channel: ``cdr`` (ROS 2) and ``ros1`` with rosbags' generated deserializers built from the
channel's schema (5-10x faster than the pure-Python mcap decoders, and the very code the
bag reader uses), falling back to mcap-ros2-support's / mcap-ros1-support's decoder
factories when rosbags cannot parse a schema; ``json`` with :func:`json.loads`. Only
channels whose type maps to FlightTable columns (or that a ``--map`` field asks for) are
decoded; the conversion is
:mod:`etsid.ingest.ros_messages` (the same as for bags, so a ROS 2 bag's ``.mcap``
storage file gives the same signals as its bag directory). JSON messages use the field
names of the ROS message they stand for; MAVLink messages as JSON (schema name
``mavlink.ATTITUDE`` …) are understood too.

A channel that cannot be decoded (unknown encoding, broken schema, bad bytes) does not
abort the file: it is skipped, counted, and named in the warnings and its channel note.
Service-event channels are listed, not decoded.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from etsid.errors import IngestError
from etsid.ingest.base import RawLog, ReadOptions
from etsid.ingest.ros_messages import Converter, TopicData, as_message
from etsid.progress import progress


def _json_decoder(data: bytes) -> Any:
    return as_message(json.loads(data))


class _Decoders:
    """Decoders per channel: rosbags' generated deserializers for ``ros2msg``/``ros1msg``
    schemas (fast, and the same code as the bag reader), else the mcap decoder factories."""

    def __init__(self) -> None:
        from mcap_ros1.decoder import DecoderFactory as Ros1Factory
        from mcap_ros2.decoder import DecoderFactory as Ros2Factory
        from rosbags.typesys import Stores, get_typestore

        self.factories = [Ros2Factory(), Ros1Factory()]
        self.store = get_typestore(Stores.EMPTY)

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
        return lambda data: deserialize(data, typename)

    def make(self, encoding: str, schema: Any) -> Callable[[bytes], Any]:
        """A decoder for ``encoding`` and ``schema``; raises ValueError when there is none."""
        if encoding == "json":
            return _json_decoder
        fast = self._rosbags(encoding, schema)
        if fast is not None:
            return fast
        for factory in self.factories:
            decoder = factory.decoder_for(encoding, schema)
            if decoder is not None:
                return decoder
        kind = f"schema encoding {schema.encoding!r}" if schema is not None else "no schema"
        raise ValueError(f"no decoder for message encoding {encoding!r} with {kind}")


def read(path: Path, options: ReadOptions) -> RawLog:
    """Read an MCAP file into a :class:`RawLog`.

    Raises
    ------
    IngestError
        Not a readable MCAP file, or one without any complete message.
    """
    from mcap.records import Channel, Header, Message, Schema
    from mcap.stream_reader import StreamReader

    path = Path(path)
    raw = RawLog(path=path, format="mcap")
    conv = Converter(options)
    decoders = _Decoders()
    schemas: dict[int, Any] = {}
    channels: dict[int, tuple[TopicData, Any]] = {}
    broken: dict[str, str] = {}
    encodings: set[str] = set()
    size = path.stat().st_size
    good_pos = 0
    messages = 0
    with path.open("rb") as handle, progress(size, f"reading {path.name}",
                                             options.progress) as bar:
        try:
            for record in StreamReader(handle).records:
                if isinstance(record, Message):
                    messages += 1
                    entry = channels.get(record.channel_id)
                    if entry is None:
                        continue
                    _take(conv, entry, record, decoders, broken)
                elif isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    if record.id not in channels:
                        channels[record.id] = _open_channel(conv, record, schemas)
                        encodings.add(record.message_encoding)
                elif isinstance(record, Header):
                    raw.extra["profile"] = record.profile
                    raw.extra["library"] = record.library
                pos = handle.tell()
                if pos - good_pos > 1 << 20:
                    bar.update(pos - good_pos)
                good_pos = pos
        except Exception as err:  # the mcap/zstd/lz4 stack raises many types on bad bytes
            why = (" ".join(str(a) for a in err.args) or type(err).__name__).splitlines()[0]
            if messages == 0 and good_pos > 0 and "EndOfFile" in (why, type(err).__name__):
                raise IngestError(f"{path}: truncated MCAP file: no complete message before "
                                  f"byte {good_pos} of {size}") from err
            if messages == 0:
                raise IngestError(f"{path}: not a readable MCAP file ({why})") from err
            raw.warnings.append(f"{path}: truncated or damaged after byte {good_pos} ({why}); "
                                f"kept {messages} message(s) before it, "
                                f"{size - good_pos} byte(s) could not be read")
    for name, why in broken.items():
        topic = conv.topics[name]
        topic.note = f"undecodable, skipped ({why})"
        raw.warnings.append(f"{name}: {topic.count} message(s) could not be decoded and were "
                            f"skipped ({why})")
    raw.extra["encodings"] = sorted(encodings)
    conv.finish(raw)
    return raw


def _open_channel(conv: Converter, record: Any, schemas: dict[int, Any]) -> tuple[TopicData, Any]:
    schema = schemas.get(record.schema_id)
    msgtype = schema.name if schema is not None else "(no schema)"
    topic = conv.topic(record.topic, msgtype)
    return topic, [record.message_encoding, schema, None]


def _take(conv: Converter, entry: tuple[TopicData, Any], record: Any, decoders: _Decoders,
          broken: dict[str, str]) -> None:
    topic, state = entry
    if not topic.decode or topic.topic in broken:
        conv.count(topic, record.log_time)
        return
    decoder = state[2]
    try:
        if decoder is None:
            decoder = state[2] = decoders.make(state[0], state[1])
        msg = decoder(record.data)
    except Exception as err:  # any decoder failure disables this channel only
        text = " ".join(str(a) for a in err.args) or type(err).__name__
        broken[topic.topic] = f"{type(err).__name__}: {text.splitlines()[0][:120]}"
        topic.spec, topic.requests = None, []
        conv.count(topic, record.log_time)
        return
    conv.add(topic, msg, record.log_time)
