"""Write a FlightTable as an MCAP file with MAVROS topics, in ROS 2, ROS 1 or JSON encoding.

The topics, rates, frames (FLU body, ENU world) and stamps are those of
:mod:`etsid.sim.writers.rosbag`. ``ros2`` uses mcap-ros2-support's writer (cdr, ``ros2``
profile), ``ros1`` mcap-ros1-support's (``ros1`` profile), ``json`` the plain mcap writer
with a JSON schema per type; JSON messages use the ROS 2 field names
(``header.stamp.sec``/``nanosec``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pandas as pd

from etsid.pwm import DEFAULT_RC_RANGE_US, RcRange
from etsid.sim.writers.rosbag import instantiate, mavros_messages

LIBRARY = "etsid"
CHUNK_SIZE = 256 * 1024
"""Uncompressed bytes per chunk (small chunks keep a cut file mostly readable)."""


def write_mcap(table: pd.DataFrame, path: Path, encoding: str = "ros2",
               rc_range_us: RcRange = DEFAULT_RC_RANGE_US,
               rates: dict[str, float] | None = None) -> Path:
    """Write ``table`` to the MCAP file ``path`` (``encoding`` ros2, ros1 or json).

    ``rc_range_us``: PWM min, centre, max (µs) of the RC and servo channels; ``rates``:
    stream rate overrides, Hz (:func:`~etsid.sim.writers.rosbag.mavros_messages`).
    """
    writers = {"ros2": _write_ros2, "ros1": _write_ros1, "json": _write_json}
    if encoding not in writers:
        raise ValueError(f"unknown MCAP encoding {encoding!r}; use ros2, ros1 or json")
    path = Path(path)
    with path.open("wb") as handle:
        writers[encoding](table, handle, rc_range_us, rates)
    return path


def _write_ros2(table: pd.DataFrame, handle: Any, rc_range_us: RcRange,
                rates: dict[str, float] | None = None) -> None:
    from mcap_ros2.writer import Writer

    from etsid.rosmsgs import typestore

    store = typestore(ros1=False)
    topics, messages = mavros_messages(table, rc_range_us, rates)
    writer = Writer(handle, chunk_size=CHUNK_SIZE)
    schemas = {msgtype: writer.register_msgdef(msgtype, store.generate_msgdef(msgtype, 2)[0])
               for _, msgtype in topics}
    for log_ns, _, topic, msgtype, fields in messages:
        writer.write_message(topic, schemas[msgtype], fields, log_time=log_ns,
                             publish_time=log_ns)
    writer.finish()


def _write_ros1(table: pd.DataFrame, handle: Any, rc_range_us: RcRange,
                rates: dict[str, float] | None = None) -> None:
    from mcap_ros1._vendor.genpy.dynamic import generate_dynamic
    from mcap_ros1.writer import Writer

    from etsid.rosmsgs import typestore

    store = typestore(ros1=True)
    topics, messages = mavros_messages(table, rc_range_us, rates)
    classes = {}
    for _, msgtype in topics:
        name = msgtype.replace("/msg/", "/")
        classes[msgtype] = generate_dynamic(name, store.generate_msgdef(msgtype)[0])[name]
    writer = Writer(handle, chunk_size=CHUNK_SIZE)
    for log_ns, _, topic, msgtype, fields in messages:
        data = store.serialize_ros1(instantiate(store, msgtype, fields), msgtype)
        msg = classes[msgtype]().deserialize(bytes(data))
        writer.write_message(topic, msg, log_time=log_ns, publish_time=log_ns)
    writer.finish()


def _json_schema(value: Any) -> dict[str, Any]:
    if isinstance(value, dict):
        return {"type": "object", "properties": {k: _json_schema(v) for k, v in value.items()}}
    if isinstance(value, list):
        return {"type": "array", "items": _json_schema(value[0]) if value else {}}
    if isinstance(value, bool):
        return {"type": "boolean"}
    if isinstance(value, str):
        return {"type": "string"}
    return {"type": ["number", "null"]}


def _plain(value: Any) -> Any:
    """JSON-safe values: NaN and inf become null."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _write_json(table: pd.DataFrame, handle: Any, rc_range_us: RcRange,
                rates: dict[str, float] | None = None) -> None:
    from mcap.writer import Writer

    _, messages = mavros_messages(table, rc_range_us, rates)
    writer = Writer(handle, chunk_size=CHUNK_SIZE)
    writer.start(profile="", library=LIBRARY)
    channels: dict[str, int] = {}
    for log_ns, _, topic, msgtype, fields in messages:
        channel = channels.get(topic)
        if channel is None:
            schema = dict(_json_schema(fields), title=msgtype)
            schema_id = writer.register_schema(name=msgtype, encoding="jsonschema",
                                               data=json.dumps(schema).encode())
            channel = channels[topic] = writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schema_id)
        writer.add_message(channel_id=channel, log_time=log_ns, publish_time=log_ns,
                           data=json.dumps(_plain(fields)).encode())
    writer.finish()
