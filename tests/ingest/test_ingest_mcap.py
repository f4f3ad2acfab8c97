"""MCAP specifics: per-channel decoding failures, encodings, JSON messages, bad files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from etsid.cli import cli
from etsid.errors import IngestError
from etsid.ingest import read_log, read_raw
from etsid.rosmsgs import typestore

T0 = 1_700_000_000 * 10**9
IMU = "sensor_msgs/msg/Imu"


def _imu(i: int) -> dict:
    stamp = T0 + i * 10_000_000
    return {"header": {"stamp": {"sec": stamp // 10**9, "nanosec": stamp % 10**9},
                       "frame_id": "base_link"},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
            "orientation_covariance": [0.0] * 9,
            "angular_velocity": {"x": 0.1 * i, "y": 0.2, "z": -0.3},
            "angular_velocity_covariance": [0.0] * 9,
            "linear_acceleration": {"x": 0.5, "y": 0.0, "z": 9.81},
            "linear_acceleration_covariance": [0.0] * 9}


def _mixed_mcap(path: Path) -> Path:
    """A good Imu channel, an Imu channel with a broken schema, a protobuf channel, json."""
    from mcap.writer import Writer

    text = typestore().generate_msgdef(IMU, 2)[0]
    from mcap_ros2.writer import Writer as Ros2Writer

    with path.open("wb") as handle:
        ros2 = Ros2Writer(handle)
        good = ros2.register_msgdef(IMU, text)
        raw: Writer = ros2._writer
        bad = raw.register_schema(IMU, "ros2msg", b"float64 x\nthis is not a field !!\n")
        bad_ch = raw.register_channel("/broken/imu", "cdr", bad)
        proto = raw.register_schema("pkg.Imu", "protobuf", b"\x00\x01")
        proto_ch = raw.register_channel("/proto/imu", "protobuf", proto)
        js = raw.register_schema("sensor_msgs/msg/BatteryState", "jsonschema", b"{}")
        js_ch = raw.register_channel("/mavros/battery", "json", js)
        for i in range(100):
            rec = T0 + i * 10_000_000 + 1_000_000
            ros2.write_message("/mavros/imu/data", good, _imu(i), log_time=rec,
                               publish_time=rec)
            raw.add_message(bad_ch, log_time=rec, publish_time=rec, data=b"\x00\x01\x00\x00")
            raw.add_message(proto_ch, log_time=rec, publish_time=rec, data=b"\x08\x01")
            if i % 10 == 0:
                msg = {"header": _imu(i)["header"], "voltage": 12.5 - 0.001 * i}
                raw.add_message(js_ch, log_time=rec, publish_time=rec,
                                data=json.dumps(msg).encode())
        ros2.finish()
    return path


def test_undecodable_channels_are_skipped_and_reported(tmp_path: Path) -> None:
    path = _mixed_mcap(tmp_path / "mixed.mcap")
    raw = read_raw(path)
    channels = {c.name: c for c in raw.channels}
    assert channels["/broken/imu"].count == 100
    assert channels["/broken/imu"].note.startswith("undecodable, skipped")
    assert any(w.startswith("/broken/imu: 100 message(s) could not be decoded")
               for w in raw.warnings)
    assert "not converted" in channels["/proto/imu"].note  # unknown type: not even decoded
    table = read_log(path)
    np.testing.assert_allclose(table["q"], -0.2, atol=1e-12)  # FLU y → FRD −y
    np.testing.assert_allclose(table["r"], 0.3, atol=1e-12)
    np.testing.assert_allclose(table["az"], -9.81, atol=1e-12)
    np.testing.assert_allclose(table["p"], 10.0 * table.index.to_numpy(), atol=1e-9)
    assert table["vbat"].iloc[0] == pytest.approx(12.5)
    assert table.attrs["mapping"]["vbat"] == "/mavros/battery.voltage"
    assert raw.extra["encodings"] == ["cdr", "json", "protobuf"]


def test_undecodable_known_type_with_unknown_encoding(tmp_path: Path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "proto.mcap"
    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start()
        schema = writer.register_schema(IMU, "protobuf", b"\x00")
        channel = writer.register_channel("/imu", "protobuf", schema)
        for i in range(5):
            writer.add_message(channel, log_time=T0 + i, publish_time=T0 + i, data=b"\x08\x01")
        writer.finish()
    raw = read_raw(path)
    assert "no decoder for message encoding 'protobuf'" in raw.channels[0].note
    with pytest.raises(IngestError, match=r"proto.mcap: no usable flight data; found /imu"):
        read_log(path)


def test_mcap_without_messages_and_random_bytes(tmp_path: Path) -> None:
    from mcap.writer import Writer

    empty = tmp_path / "empty.mcap"
    with empty.open("wb") as handle:
        writer = Writer(handle)
        writer.start()
        writer.finish()
    with pytest.raises(IngestError, match="empty.mcap: no usable flight data; found no messages"):
        read_log(empty)
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(bytes(range(256)))
    with pytest.raises(IngestError, match="junk.mcap: not an MCAP file"):
        read_log(junk)
    result = CliRunner().invoke(cli, ["inspect", str(junk)])
    assert result.exit_code == 1 and "Traceback" not in result.output
