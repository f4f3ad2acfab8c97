"""The vectorised ROS/MCAP path gives bit-identical signals to the per-message path.

Every file is read twice, with :data:`etsid.ingest.ros.fast.decode.ENABLED` on and off, and the
raw logs (signals, times, counts, notes, warnings) must be equal exactly.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_ingest_ros_px4 import px4_messages, write_px4_bag
from test_ingest_ros_roundtrip import synthetic_table

from etsid.ingest import ReadOptions, read_raw
from etsid.ingest.base import RawLog
from etsid.ingest.ros.fast import decode as fast_decode
from etsid.ingest.ros.fast import mcap as fast_mcap
from etsid.rosmsgs import typestore
from etsid.sim.writers.mcapfile import write_mcap
from etsid.sim.writers.rosbag import instantiate, write_ros1_bag, write_ros2_bag

DATA = Path(__file__).parents[1] / "data" / "ros"
SITL = DATA / "mavros_from_sitl"
REAL = [SITL / "mavros_vtol.bag", SITL / "mavros_vtol_ros2_db3",
        SITL / "mavros_vtol_ros2_db3" / "mavros_vtol_ros2_db3.db3", SITL / "mavros_vtol_ros2_mcap",
        SITL / "mavros_vtol_ros2_mcap" / "mavros_vtol_ros2_mcap.mcap",
        SITL / "mavros_vtol_ros1.mcap", SITL / "vtol_json.mcap", DATA / "xsens_imu_real.bag",
        DATA / "ros2_old_metadata_bag", DATA / "ros2_topics_and_services.mcap"]
Message = tuple[str, str, int, dict[str, Any]]


def _read_both(path: Path, monkeypatch: pytest.MonkeyPatch,
               options: ReadOptions | None = None) -> tuple[RawLog, RawLog, int]:
    """(fast, slow, messages converted by the vectorised path)."""
    before = fast_decode.STATS["fast"]
    fast = read_raw(path, options) if options else read_raw(path)
    used = fast_decode.STATS["fast"] - before
    with monkeypatch.context() as m:
        m.setattr(fast_decode, "ENABLED", False)
        slow = read_raw(path, options) if options else read_raw(path)
    return fast, slow, used


def _same(fast: RawLog, slow: RawLog) -> None:
    assert fast.start_time == slow.start_time
    assert fast.channels == slow.channels
    assert fast.dropped == slow.dropped
    assert fast.repaired == slow.repaired
    assert fast.warnings == slow.warnings
    assert len(fast.signals) == len(slow.signals)
    for a, b in zip(fast.signals, slow.signals, strict=True):
        assert (a.column, a.source, a.priority) == (b.column, b.source, b.priority)
        assert a.t.dtype == b.t.dtype == np.float64
        np.testing.assert_array_equal(a.t, b.t, strict=True, err_msg=a.source)
        np.testing.assert_array_equal(a.values, b.values, strict=True, err_msg=a.source)


@pytest.mark.parametrize("path", REAL, ids=lambda p: p.name)
def test_real_files_fast_equals_slow(path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fast, slow, _ = _read_both(path, monkeypatch)
    _same(fast, slow)


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("fast")
    table = synthetic_table(duration=5.0)
    return {"ros1": write_ros1_bag(table, tmp / "g.bag"),
            "ros2-db3": write_ros2_bag(table, tmp / "g_db3", storage="sqlite3"),
            "ros2-mcap": write_ros2_bag(table, tmp / "g_mcap", storage="mcap"),
            "mcap-ros2": write_mcap(table, tmp / "g2.mcap", encoding="ros2"),
            "mcap-ros1": write_mcap(table, tmp / "g1.mcap", encoding="ros1"),
            "px4": write_px4_bag(tmp / "px4_bag", px4_messages(120))}


@pytest.mark.parametrize("name", ["ros1", "ros2-db3", "ros2-mcap", "mcap-ros2", "mcap-ros1",
                                  "px4"])
@pytest.mark.parametrize("batch", [fast_decode.BATCH, 7])
def test_generated_files_fast_equals_slow(generated: dict[str, Path], name: str, batch: int,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(fast_decode, "BATCH", batch)
    fast, slow, used = _read_both(generated[name], monkeypatch)
    _same(fast, slow)
    total = sum(c.count for c in fast.channels)
    assert used == total  # every message of these files takes the vectorised path


def test_field_request_topic_takes_the_slow_path(generated: dict[str, Path],
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    from etsid.ingest.mapping import parse_override

    options = ReadOptions(overrides=[parse_override("p=/mavros/imu/data.angular_velocity.x")])
    fast, slow, used = _read_both(generated["ros1"], monkeypatch, options)
    _same(fast, slow)
    imu = next(c for c in fast.channels if c.name == "/mavros/imu/data")
    assert 0 < used == sum(c.count for c in fast.channels) - imu.count


# ---------------------------------------------------------------------------
# odd inputs: written message by message


def _odd_messages() -> list[Message]:
    """Imu with varying frame_id lengths and stamps, RC arrays empty or varying, an RC topic
    whose frame_id and channel count trade off to the same message length."""
    base = 1_700_000_000 * 10**9
    out: list[Message] = []
    frames = ["base_link", "", "a", "base_link", "imu_link_long_name"]
    for i in range(300):
        rec = base + i * 10_000_000 + 1_000_000
        stamp = base + i * 10_000_000 if i % 37 else 0  # some unset stamps
        if i == 150:
            stamp = base - 3 * 86_400 * 10**9  # implausible
        header = {"stamp": {"sec": stamp // 10**9, "nanosec": stamp % 10**9},
                  "frame_id": frames[(i // 40) % len(frames)]}
        fixed = {**header, "frame_id": "map"}
        out.append(("/mavros/imu/data", "sensor_msgs/msg/Imu", rec, {
            "header": header, "orientation": {"w": 0.9, "x": 0.1 * np.sin(i), "z": 0.3},
            "angular_velocity": {"x": 0.01 * i, "y": -0.2, "z": 1e-7 * i},
            "linear_acceleration": {"x": 0.5, "y": 0.1 * i, "z": 9.8},
            "orientation_covariance": [-1.0 if i % 50 < 5 else 0.0] + [0.0] * 8,
            "angular_velocity_covariance": [0.0] * 9,
            "linear_acceleration_covariance": [-1.0 if i > 280 else 0.1] + [0.0] * 8}))
        if i % 4 == 0:
            n = 8 if i < 100 else (0 if i < 160 else 8 + (i // 4) % 3)
            out.append(("/mavros/rc/in", "mavros_msgs/msg/RCIn", rec + 1, {
                "header": header, "rssi": 200,
                "channels": [1000 + 3 * i + k for k in range(n)]}))
            out.append(("/mavros/rc/out", "mavros_msgs/msg/RCOut", rec + 2, {
                "header": fixed, "channels": []}))
            # "ab" + 4 channels and "abcd" + 3 channels: same ROS 1 length, other layout
            two = (i // 4) % 2 == 0
            out.append(("/mavros/rc/in_tradeoff", "mavros_msgs/msg/RCIn", rec + 3, {
                "header": {**header, "frame_id": "ab" if two else "abcd"}, "rssi": 1,
                "channels": [1100 + i + k for k in range(4 if two else 3)]}))
        if i % 5 == 0:
            out.append(("/mavros/distance_sensor/rangefinder_pub", "sensor_msgs/msg/Range",
                        rec + 4, {"header": fixed, "range": 1.0 + 0.01 * i,
                                  "min_range": 0.2, "max_range": 4.0 if i % 3 else 1.5}))
            out.append(("/mavros/setpoint_raw/target_attitude", "mavros_msgs/msg/AttitudeTarget",
                        rec + 5, {"header": fixed, "type_mask": [0, 7, 64, 128][i % 4],
                                  "orientation": {"w": 1.0},
                                  "body_rate": {"x": 0.1, "y": 0.2 * i, "z": -0.3},
                                  "thrust": 0.55}))
    return out


def _write_ros1(path: Path, messages: list[Message], two_imu_publishers: bool = False) -> Path:
    from rosbags.rosbag1 import Writer

    store = typestore(ros1=True)
    with Writer(path) as writer:
        conns: dict[str, Any] = {}
        if two_imu_publishers:  # a second connection on the same topic
            conns["imu2"] = writer.add_connection("/mavros/imu/data", "sensor_msgs/msg/Imu",
                                                  typestore=store, callerid="/other")
        for i, (topic, msgtype, rec, fields) in enumerate(messages):
            if two_imu_publishers and topic == "/mavros/imu/data" and i % 3 == 0:
                topic = "imu2"
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=store)
            msg = instantiate(store, msgtype, fields)
            writer.write(conns[topic], rec, store.serialize_ros1(msg, msgtype))
    return path


def _write_ros2(path: Path, messages: list[Message], storage: str) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = typestore()
    plugin = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}[storage]
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conns: dict[str, Any] = {}
        for topic, msgtype, rec, fields in messages:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=store)
            msg = instantiate(store, msgtype, fields)
            writer.write(conns[topic], rec, store.serialize_cdr(msg, msgtype))
    return path


def _write_mcap(path: Path, messages: list[Message], ros1: bool, chunked: bool = True) -> Path:
    from mcap.writer import Writer

    store = typestore(ros1=ros1)
    with path.open("wb") as handle:
        writer = Writer(handle, chunk_size=4096, use_chunking=chunked)
        writer.start(profile="ros1" if ros1 else "ros2", library="etsid-test")
        channels: dict[str, int] = {}
        for topic, msgtype, rec, fields in messages:
            if topic not in channels:
                text = store.generate_msgdef(msgtype, **({} if ros1 else {"ros_version": 2}))[0]
                schema = writer.register_schema(msgtype, "ros1msg" if ros1 else "ros2msg",
                                                text.encode())
                channels[topic] = writer.register_channel(topic, "ros1" if ros1 else "cdr",
                                                          schema)
            msg = instantiate(store, msgtype, fields)
            data = store.serialize_ros1(msg, msgtype) if ros1 else store.serialize_cdr(
                msg, msgtype)
            writer.add_message(channels[topic], log_time=rec, data=bytes(data),
                               publish_time=rec)
        writer.finish()
    return path


@pytest.fixture(scope="module")
def odd(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("odd")
    msgs = _odd_messages()
    shuffled = msgs[:40] + msgs[80:120] + msgs[40:80] + msgs[120:]  # time goes back
    imu = [i for i, m in enumerate(msgs) if m[0] == "/mavros/imu/data"]
    dup = list(msgs)
    dup[imu[11]] = (*dup[imu[11]][:2], dup[imu[10]][2], dup[imu[11]][3])  # same record time
    return {"ros1": _write_ros1(tmp / "odd.bag", msgs),
            "ros1-unordered": _write_ros1(tmp / "unordered.bag", shuffled),
            "ros1-two-publishers": _write_ros1(tmp / "two.bag", msgs, two_imu_publishers=True),
            "ros2-db3": _write_ros2(tmp / "odd_db3", msgs, "sqlite3"),
            "ros2-mcap": _write_ros2(tmp / "odd_mcap", msgs, "mcap"),
            "ros2-db3-dup": _write_ros2(tmp / "dup_db3", dup, "sqlite3"),
            "ros2-mcap-dup": _write_ros2(tmp / "dup_mcap", dup, "mcap"),
            "mcap-ros2": _write_mcap(tmp / "odd2.mcap", msgs, ros1=False),
            "mcap-ros1": _write_mcap(tmp / "odd1.mcap", msgs, ros1=True),
            "mcap-unchunked": _write_mcap(tmp / "odd3.mcap", msgs, ros1=False, chunked=False)}


@pytest.mark.parametrize("name", ["ros1", "ros1-unordered", "ros1-two-publishers",
                                  "ros2-db3", "ros2-mcap",
                                  "ros2-db3-dup", "ros2-mcap-dup",
                                  "mcap-ros2", "mcap-ros1", "mcap-unchunked"])
@pytest.mark.parametrize("batch", [fast_decode.BATCH, 7, 1])
def test_odd_inputs_fast_equals_slow(odd: dict[str, Path], name: str, batch: int,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(fast_decode, "BATCH", batch)
    fast, slow, used = _read_both(odd[name], monkeypatch)
    _same(fast, slow)
    assert used > 0
    assert any("header.stamp" in r.reason for r in fast.repaired)
    rc = next(c for c in fast.channels if c.name == "/mavros/rc/in")
    assert rc.count == 75


def test_mcap_runs_span_unchunked_records(odd: dict[str, Path], monkeypatch: pytest.MonkeyPatch
                                          ) -> None:

    monkeypatch.setattr(fast_mcap, "RUN_BYTES", 500)  # many small runs
    fast, slow, used = _read_both(odd["mcap-unchunked"], monkeypatch)
    _same(fast, slow)
    assert used > 0


def test_layout_refuses_big_endian_cdr_and_short_messages() -> None:
    store = typestore()
    msg = instantiate(store, "sensor_msgs/msg/Range", {"range": 1.5})
    data = bytes(store.serialize_cdr(msg, "sensor_msgs/msg/Range"))
    layout = fast_decode.layout_of(store.fielddefs, "sensor_msgs/msg/Range", data, cdr=True)
    assert layout.size == len(data) and "range" in layout.fields
    with pytest.raises(fast_decode.Unsupported):
        fast_decode.layout_of(store.fielddefs, "sensor_msgs/msg/Range",
                           data[:1] + b"\0" + data[2:], cdr=True)  # big-endian flag
    with pytest.raises(fast_decode.Unsupported):
        fast_decode.layout_of(store.fielddefs, "sensor_msgs/msg/Range", data[:-6], cdr=True)
