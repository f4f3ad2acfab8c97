"""px4_msgs topics (FRD/NED, µs timestamps) and bags without embedded message definitions."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pytest

from etsid.frames import euler_to_quat
from etsid.ingest import read_log, read_raw
from etsid.rosmsgs import typestore
from etsid.sim.writers.rosbag import instantiate

T0 = 1_700_000_000 * 10**9
BOOT_US = 50_000_000  # the autopilot booted 50 s before the recording started


def px4_messages(n: int = 400) -> list[tuple[str, str, int, dict]]:
    """(topic, type, record ns, fields) at 200 Hz, all axes with known non-zero values."""
    out = []
    for i in range(n):
        t = i * 0.005
        us = BOOT_US + i * 5000
        roll, pitch, yaw = 0.1 + 0.2 * np.sin(t), -0.05, 2.0 + 0.3 * t
        w, x, y, z = euler_to_quat(np.array(roll), np.array(pitch), np.array(yaw))
        rec = T0 + i * 5_000_000 + 300_000
        out += [
            ("/fmu/out/vehicle_angular_velocity", "px4_msgs/msg/VehicleAngularVelocity", rec,
             {"timestamp": us, "timestamp_sample": us, "xyz": [0.3 + t, -0.2, 0.1]}),
            ("/fmu/out/vehicle_attitude", "px4_msgs/msg/VehicleAttitude", rec,
             {"timestamp": us, "timestamp_sample": us, "q": [float(w), float(x), float(y),
                                                            float(z)]}),
            ("/fmu/out/sensor_combined", "px4_msgs/msg/SensorCombined", rec,
             {"timestamp": us, "gyro_rad": [0.31, -0.21, 0.11],
              "accelerometer_m_s2": [0.5, -0.4, -9.7]}),
        ]
        if i % 4 == 0:
            out += [
                ("/fmu/out/manual_control_setpoint", "px4_msgs/msg/ManualControlSetpoint", rec,
                 {"timestamp": us, "roll": 0.2, "pitch": -0.3, "yaw": 0.1, "throttle": 0.0}),
                ("/fmu/out/vehicle_rates_setpoint", "px4_msgs/msg/VehicleRatesSetpoint", rec,
                 {"timestamp": us, "roll": 0.4, "pitch": -0.5, "yaw": 0.6,
                  "thrust_body": [0.0, 0.0, -0.6]}),
                ("/fmu/out/actuator_motors", "px4_msgs/msg/ActuatorMotors", rec,
                 {"timestamp": us, "control": [0.1, 0.2, 0.3, 0.4] + [float("nan")] * 8}),
                ("/fmu/out/vehicle_local_position", "px4_msgs/msg/VehicleLocalPosition", rec,
                 {"timestamp": us, "vx": 1.0, "vy": -2.0, "vz": 0.5, "z": -3.0,
                  "dist_bottom": 2.5, "dist_bottom_valid": True}),
                ("/fmu/out/distance_sensor", "px4_msgs/msg/DistanceSensor", rec,
                 {"timestamp": us, "current_distance": 2.4, "orientation": 25}),
                ("/fmu/out/battery_status", "px4_msgs/msg/BatteryStatus", rec,
                 {"timestamp": us, "voltage_v": 15.2}),
            ]
    return out


def write_px4_bag(path: Path, messages: list[tuple[str, str, int, dict]]) -> Path:
    from rosbags.rosbag2 import Writer

    store = typestore()
    with Writer(path, version=9) as writer:
        conns = {}
        for topic, msgtype, rec, fields in messages:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=store)
            msg = instantiate(store, msgtype, fields)
            writer.write(conns[topic], rec, store.serialize_cdr(msg, msgtype))
    return path


@pytest.fixture(scope="module")
def px4_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_px4_bag(tmp_path_factory.mktemp("px4") / "px4_bag", px4_messages())


def test_px4_topics_frd_ned_values(px4_bag: Path) -> None:
    table = read_log(px4_bag)
    mapping = table.attrs["mapping"]
    assert mapping["p"] == "/fmu/out/vehicle_angular_velocity.xyz[0]"
    assert mapping["ax"] == "/fmu/out/sensor_combined.accelerometer_m_s2[0]"
    assert mapping["alt"] == "/fmu/out/distance_sensor.current_distance"
    assert mapping["u_thrust"] == "/fmu/out/manual_control_setpoint.throttle"
    assert table.attrs["rate_hz"] == pytest.approx(200.0)
    np.testing.assert_allclose(table["p"], 0.3 + table.index.to_numpy(), atol=1e-6)
    expected = {"q": -0.2, "r": 0.1, "pitch": -0.05, "ax": 0.5, "ay": -0.4, "az": -9.7,
                "u_roll": 0.2, "u_pitch": -0.3, "u_yaw": 0.1, "u_thrust": 0.5, "sp_p": 0.4,
                "sp_q": -0.5, "sp_r": 0.6, "m1": 0.1, "m4": 0.4, "vx": 1.0, "vy": -2.0,
                "vz": 0.5, "alt": 2.4, "vbat": 15.2}
    for column, value in expected.items():
        np.testing.assert_allclose(table[column].dropna(), value, atol=1e-5, err_msg=column)
    assert "m5" not in table.columns  # NaN = unused motor
    yaw = 2.0 + 0.3 * table.index.to_numpy()
    np.testing.assert_allclose(table["yaw"], np.angle(np.exp(1j * yaw)), atol=1e-5)
    # boot-clock µs stamps are shifted onto the record clock (0.3 ms transport delay)
    assert table.attrs["start_time"] == pytest.approx(T0 * 1e-9, abs=1e-3)


def test_bag_without_definitions_uses_shipped_msg_files(px4_bag: Path, tmp_path: Path) -> None:
    bare = tmp_path / "bare"
    bare.mkdir()
    for src in px4_bag.iterdir():
        (bare / src.name).write_bytes(src.read_bytes())
    db3 = next(bare.glob("*.db3"))
    with sqlite3.connect(db3) as con:
        con.execute("DELETE FROM message_definitions")
    meta = (bare / "metadata.yaml").read_text()
    assert "px4_msgs/msg/VehicleAttitude" in meta
    from rosbags.highlevel import AnyReader, AnyReaderError

    with pytest.raises(AnyReaderError, match="no type definitions"), AnyReader([db3]):
        pass  # rosbags alone cannot decode it
    pd_bare, pd_full = read_log(bare), read_log(px4_bag)
    np.testing.assert_allclose(pd_bare.to_numpy(), pd_full.to_numpy(), equal_nan=True)


def test_zero_px4_timestamps_are_dropped_and_counted(tmp_path: Path) -> None:
    messages = [m for m in px4_messages(100) if "angular_velocity" in m[0]]
    for topic, _, _, fields in messages[:5]:
        assert topic.endswith("angular_velocity")
        fields["timestamp"] = 0
    raw = read_raw(write_px4_bag(tmp_path / "zero", messages))
    assert any(i.reason == "timestamp 0 (not set)" and i.count == 5 for i in raw.dropped)
    assert raw.signals[0].t.size == 95
