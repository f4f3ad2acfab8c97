"""PX4 ULog: real logs with old and newer topic names, new-topic decoding, bad input."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from pyulog import ULog

from etsid.cli import cli
from etsid.errors import IngestError
from etsid.ingest import read_log, read_raw
from etsid.ingest.base import Override, ReadOptions
from etsid.ingest.ulog import Topic, signals

DATA = Path(__file__).parents[1] / "data"
CUBE = DATA / "px4_cubeorange_real.ulg"
SITL = DATA / "px4_sitl_tagged.ulg"


@pytest.fixture(scope="module")
def cube() -> object:
    return read_raw(CUBE)


def test_real_log_rates_and_sources(cube: object) -> None:
    sig = {s.source: s for s in cube.signals}  # type: ignore[attr-defined]
    p = sig["vehicle_angular_velocity.xyz[0]"]
    assert p.column == "p" and p.rate_hz == pytest.approx(279, abs=3)
    ctrl = sig["actuator_controls_0.control[0]"]
    assert ctrl.column == "u_roll" and ctrl.priority > sig["manual_control_setpoint.y"].priority
    assert sig["actuator_controls_0.control[3]"].column == "u_thrust"
    assert sig["manual_control_setpoint.x"].column == "u_pitch"  # old field names
    notes = {c.name: c.note for c in cube.channels}  # type: ignore[attr-defined]
    assert "torque" in notes["actuator_controls_0"]
    assert sig["sensor_combined.gyro_rad[0]"].priority > p.priority


def test_real_log_values_match_pyulog(cube: object) -> None:
    sig = {s.source: s for s in cube.signals}  # type: ignore[attr-defined]
    ulog = ULog(str(CUBE), ["vehicle_angular_velocity", "vehicle_attitude"])
    av = ulog.get_dataset("vehicle_angular_velocity").data
    np.testing.assert_allclose(sig["vehicle_angular_velocity.xyz[1]"].values, av["xyz[1]"])
    np.testing.assert_allclose(sig["vehicle_angular_velocity.xyz[1]"].t,
                               av["timestamp_sample"] * 1e-6)
    q = ulog.get_dataset("vehicle_attitude").data
    w, x, y, z = (q[f"q[{i}]"].astype(float) for i in range(4))
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    np.testing.assert_allclose(sig["vehicle_attitude.q"].values if
                               sig["vehicle_attitude.q"].column == "roll" else
                               next(s.values for s in cube.signals  # type: ignore[attr-defined]
                                    if s.column == "roll"), roll, atol=1e-6)


def test_real_log_table() -> None:
    out = read_log(CUBE)
    assert {"p", "q", "r", "roll", "u_roll", "u_thrust", "sp_p", "m1", "vbat", "alt"} <= \
        set(out.columns)
    assert out.attrs["mapping"]["u_thrust"] == "manual_control_setpoint.z"
    assert out.attrs["start_time"] == pytest.approx(1618986638, abs=86400)  # 2021-04-21
    assert out["u_thrust"].dropna().between(0, 1).all()


def test_sitl_log_falls_back_to_controller_commands() -> None:
    out = read_log(SITL)
    # manual_control_setpoint has one sample there: the controller's commands are used
    assert out.attrs["mapping"]["u_roll"] == "actuator_controls_0.control[0]"
    assert out.attrs["mapping"]["m1"] == "actuator_outputs.output[0]"
    assert out.attrs["mapping"]["p"] == "vehicle_angular_velocity.xyz[0]"
    assert out.index[-1] > 10.0


def test_new_topic_names_decode() -> None:
    t = np.arange(5) * 1000.0 + 1e6
    topics = {
        "actuator_motors": Topic("actuator_motors", {
            "timestamp": t, **{f"control[{i}]": np.full(5, 0.1 * i) for i in range(8)}}),
        "vehicle_thrust_setpoint": Topic("vehicle_thrust_setpoint", {
            "timestamp": t, "xyz[0]": np.zeros(5), "xyz[1]": np.zeros(5),
            "xyz[2]": np.full(5, -0.6)}),
        "vehicle_torque_setpoint": Topic("vehicle_torque_setpoint", {
            "timestamp": t, **{f"xyz[{i}]": np.full(5, 0.01 * (i + 1)) for i in range(3)}}),
        "manual_control_setpoint": Topic("manual_control_setpoint", {
            "timestamp": t, "roll": np.full(5, 0.2), "pitch": np.full(5, -0.1),
            "yaw": np.zeros(5), "throttle": np.full(5, 0.0), "valid": np.ones(5, bool)}),
    }
    sig = {s.source: s for s in signals(topics, ReadOptions(), [])}
    assert sig["actuator_motors.control[3]"].column == "m4"
    np.testing.assert_allclose(sig["actuator_motors.control[3]"].values, 0.3)
    assert sig["vehicle_thrust_setpoint.xyz[2]"].column == "u_thrust"
    np.testing.assert_allclose(sig["vehicle_thrust_setpoint.xyz[2]"].values, 0.6)
    assert sig["vehicle_torque_setpoint.xyz[1]"].column == "u_pitch"
    np.testing.assert_allclose(sig["manual_control_setpoint.throttle"].values, 0.5)  # -1..1
    assert sig["manual_control_setpoint.roll"].priority == 0
    np.testing.assert_allclose(sig["vehicle_thrust_setpoint.xyz[2]"].t, t * 1e-6)


def test_override_field() -> None:
    out = read_log(SITL, ReadOptions(overrides=[Override("p", "sensor_combined",
                                                         "gyro_rad[0]")]))
    assert out.attrs["mapping"]["p"] == "sensor_combined.gyro_rad[0]"
    with pytest.raises(IngestError, match="no such field"):
        read_log(SITL, ReadOptions(overrides=[Override("p", "sensor_combined", "nope")]))


def test_truncated_ulog_gives_valid_part_and_warning(tmp_path: Path) -> None:
    cut = tmp_path / "cut.ulg"
    cut.write_bytes(CUBE.read_bytes()[:460000])
    out = read_log(cut)
    warn = [w for w in out.attrs["warnings"] if "truncated" in w]
    assert warn and "43 bytes" in warn[0]
    assert 2.0 < out.index[-1] < 6.0


@pytest.mark.parametrize(("content", "match"), [
    (b"", "empty file"),
    (b"ULog\x01\x12\x35\x01" + bytes(range(256)) * 3, "no usable flight data"),
    (b"random bytes, not a ulog at all", "not a PX4 ULog file"),
])
def test_bad_files(tmp_path: Path, content: bytes, match: str) -> None:
    path = tmp_path / "bad.ulg"
    path.write_bytes(content)
    with pytest.raises(IngestError, match=match):
        read_log(path)
    result = CliRunner().invoke(cli, ["ingest", str(path), "-o", str(tmp_path / "o.csv")])
    assert result.exit_code == 1
    assert "Traceback" not in result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and match in lines[0] and str(path) in lines[0]


def _ulog_message(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


def write_pwm_ulog(path: Path, rc: tuple[int, ...], outputs: tuple[float, ...]) -> Path:
    """A ULog (written byte by byte, read by pyulog) with input_rc and actuator_outputs at
    constant known PWM, 50 Hz, plus vehicle_angular_velocity."""
    topics = [
        ("vehicle_angular_velocity", "uint64_t timestamp;uint64_t timestamp_sample;float[3] xyz;"),
        ("input_rc", "uint64_t timestamp;uint16_t[18] values;"),
        ("actuator_outputs", "uint64_t timestamp;uint32_t noutputs;float[16] output;"),
    ]
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0))
    out += _ulog_message(b"B", bytes(16) + bytes(24))
    for name, fields in topics:
        out += _ulog_message(b"F", f"{name}:{fields}".encode())
    for msg_id, (name, _) in enumerate(topics):
        out += _ulog_message(b"A", struct.pack("<BH", 0, msg_id) + name.encode())
    pwm_in = (*rc, *([0] * (18 - len(rc))))
    pwm_out = (*outputs, *([0.0] * (16 - len(outputs))))
    for k in range(100):
        us = 1_000_000 + 20_000 * k
        out += _ulog_message(b"D", struct.pack("<HQQ3f", 0, us, us, 0.0, 0.0, 0.0))
        out += _ulog_message(b"D", struct.pack("<HQ18H", 1, us, *pwm_in))
        out += _ulog_message(b"D", struct.pack("<HQI16f", 2, us, len(outputs), *pwm_out))
    path.write_bytes(bytes(out))
    return path


@pytest.mark.parametrize(("rc_range", "sticks", "motors", "clipped"), [
    ((1000.0, 1500.0, 2000.0), (-1.0, 0.5, 0.25, 1.0), (0.0, 0.5, 1.0, 0.9),
     {"input_rc.values[3]", "actuator_outputs.output[2]"}),
    ((1100.0, 1500.0, 1900.0), (-1.0, 0.625, 0.1875, 1.0), (0.0, 0.5, 1.0, 1.0),
     {"input_rc.values[0]", "input_rc.values[3]", "actuator_outputs.output[0]",
      "actuator_outputs.output[2]"}),
])
def test_rc_and_motor_pwm_use_the_configured_range(
        tmp_path: Path, rc_range: tuple[float, float, float], sticks: tuple[float, ...],
        motors: tuple[float, ...], clipped: set[str]) -> None:
    path = write_pwm_ulog(tmp_path / "pwm.ulg", (1000, 1750, 1250, 2100),
                          (1000.0, 1500.0, 2050.0, 1900.0))
    raw = read_raw(path, ReadOptions(rc_range_us=rc_range))
    sig = {s.source: s for s in raw.signals}
    for i, (column, want) in enumerate(zip(("u_roll", "u_pitch", "u_thrust", "u_yaw"), sticks,
                                           strict=True)):
        assert sig[f"input_rc.values[{i}]"].column == column
        np.testing.assert_allclose(sig[f"input_rc.values[{i}]"].values, want, atol=1e-12)
    for i, want in enumerate(motors):
        assert sig[f"actuator_outputs.output[{i}]"].column == f"m{i + 1}"
        np.testing.assert_allclose(sig[f"actuator_outputs.output[{i}]"].values, want,
                                   atol=1e-12)
    counts = {i.signal: i.count for i in raw.repaired if "PWM outside" in i.reason}
    assert counts == dict.fromkeys(clipped, 100)


def test_land_detector_touch_down_stages() -> None:
    # the real CubeOrange hop: the detector says airborne for 1.15 s, 0.62 s of it with
    # ground contact (PX4's stage before lift-off); maybe_landed counts as contact too
    out = read_log(CUBE)
    assert out.attrs["mapping"]["ground_contact"] == "vehicle_land_detected.ground_contact"
    rate = out.attrs["rate_hz"]
    air = out["landed"] < 0.5
    assert air.sum() / rate == pytest.approx(1.15, abs=0.02)
    assert (air & (out["ground_contact"] > 0.5)).sum() / rate == pytest.approx(0.62, abs=0.02)
    assert set(np.unique(out["ground_contact"].dropna())) <= {0.0, 1.0}
