"""A PX4 log of the high-rate logging profile: ``sensor_gyro``/``sensor_accel`` at 205 Hz,
``vehicle_attitude_setpoint`` and ``vehicle_rates_setpoint`` with the scalar ``thrust`` of
PX4 ≤ 1.9, beside a slower ``sensor_combined``.

The ULog is written byte by byte (pyulog has no writer) with the message formats of a real
PX4 v1.8.2 log (the format section of ``px4_coaxocto_stabilized_real.ulg`` in
../shared/data/logs, copied field by field below). Before issue 10 etsid mapped only
``sp_p/sp_q/sp_r`` from such a log and refused identify with "no data in p, q, r".
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from etsid.ident import IdentConfig, identify
from etsid.ident.inputs import load_for_ident
from etsid.ingest import read_log

# message formats of PX4 v1.8.2 (type, array length or 0, field), as in the real log
FORMATS: dict[str, list[tuple[str, int, str]]] = {
    "sensor_gyro": [
        ("uint64_t", 0, "timestamp"), ("uint64_t", 0, "integral_dt"),
        ("uint64_t", 0, "error_count"), ("float", 0, "x"), ("float", 0, "y"),
        ("float", 0, "z"), ("float", 0, "x_integral"), ("float", 0, "y_integral"),
        ("float", 0, "z_integral"), ("float", 0, "temperature"), ("float", 0, "range_rad_s"),
        ("float", 0, "scaling"), ("uint32_t", 0, "device_id"), ("int16_t", 0, "x_raw"),
        ("int16_t", 0, "y_raw"), ("int16_t", 0, "z_raw"), ("int16_t", 0, "temperature_raw")],
    "sensor_accel": [
        ("uint64_t", 0, "timestamp"), ("uint64_t", 0, "integral_dt"),
        ("uint64_t", 0, "error_count"), ("float", 0, "x"), ("float", 0, "y"),
        ("float", 0, "z"), ("float", 0, "x_integral"), ("float", 0, "y_integral"),
        ("float", 0, "z_integral"), ("float", 0, "temperature"), ("float", 0, "range_m_s2"),
        ("float", 0, "scaling"), ("uint32_t", 0, "device_id"), ("int16_t", 0, "x_raw"),
        ("int16_t", 0, "y_raw"), ("int16_t", 0, "z_raw"), ("int16_t", 0, "temperature_raw")],
    "sensor_combined": [
        ("uint64_t", 0, "timestamp"), ("float", 3, "gyro_rad"),
        ("uint32_t", 0, "gyro_integral_dt"), ("int32_t", 0, "accelerometer_timestamp_relative"),
        ("float", 3, "accelerometer_m_s2"), ("uint32_t", 0, "accelerometer_integral_dt"),
        ("uint8_t", 4, "_padding0")],
    "vehicle_rates_setpoint": [
        ("uint64_t", 0, "timestamp"), ("float", 0, "roll"), ("float", 0, "pitch"),
        ("float", 0, "yaw"), ("float", 0, "thrust")],
    "vehicle_attitude_setpoint": [
        ("uint64_t", 0, "timestamp"), ("float", 0, "roll_body"), ("float", 0, "pitch_body"),
        ("float", 0, "yaw_body"), ("float", 0, "yaw_sp_move_rate"), ("float", 4, "q_d"),
        ("float", 0, "thrust"), ("float", 0, "landing_gear"), ("bool", 0, "q_d_valid"),
        ("bool", 0, "roll_reset_integral"), ("bool", 0, "pitch_reset_integral"),
        ("bool", 0, "yaw_reset_integral"), ("bool", 0, "fw_control_yaw"),
        ("bool", 0, "disable_mc_yaw_control"), ("bool", 0, "apply_flaps"),
        ("uint8_t", 1, "_padding0")],
}
CODES = {"uint64_t": "Q", "int32_t": "i", "uint32_t": "I", "int16_t": "h", "float": "f",
         "bool": "?", "uint8_t": "B"}
RATES = {"sensor_gyro": 205.0, "sensor_accel": 205.0, "sensor_combined": 10.0,
         "vehicle_rates_setpoint": 100.0, "vehicle_attitude_setpoint": 50.0}
DURATION = 30.0
T0_US = 5_000_000
TAU = 0.08  # s, first-order rate response to the rate setpoint


def _message(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


def _format_text(name: str) -> bytes:
    fields = ";".join(f"{t}[{n}] {f}" if n else f"{t} {f}" for t, n, f in FORMATS[name])
    return f"{name}:{fields};".encode()


def _pack(name: str, values: dict[str, object]) -> bytes:
    """One data record; trailing padding is not logged (ULog format)."""
    fields = FORMATS[name]
    while fields and fields[-1][2].startswith("_padding"):
        fields = fields[:-1]
    out = b""
    for t, n, f in fields:
        code = CODES[t]
        value = values.get(f, [0] * n if n else 0)
        out += struct.pack(f"<{n or 1}{code}", *(value if n else [value]))
    return out


def rate_setpoints(t: np.ndarray) -> np.ndarray:
    """Known rate setpoints (rad/s), one column per axis: sums of sines."""
    return np.stack([0.6 * np.sin(2 * np.pi * 0.7 * t) + 0.3 * np.sin(2 * np.pi * 1.9 * t),
                     0.5 * np.sin(2 * np.pi * 0.5 * t + 1.0) + 0.2 * np.sin(2 * np.pi * 2.3 * t),
                     0.4 * np.sin(2 * np.pi * 0.3 * t + 2.0)], axis=1)


def attitude_setpoint(t: np.ndarray) -> np.ndarray:
    """Known roll, pitch, yaw setpoints, rad."""
    return np.stack([0.2 * np.sin(2 * np.pi * 0.2 * t), 0.1 * np.cos(2 * np.pi * 0.3 * t),
                     0.5 + 0.4 * np.sin(2 * np.pi * 0.05 * t)], axis=1)


def _quat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """qz(yaw) ⊗ qy(pitch) ⊗ qx(roll) by Hamilton products (w, x, y, z)."""
    def mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        w1, x1, y1, z1 = a
        w2, x2, y2, z2 = b
        return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                         w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                         w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                         w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    qx = np.array([np.cos(roll / 2), np.sin(roll / 2), 0.0, 0.0])
    qy = np.array([np.cos(pitch / 2), 0.0, np.sin(pitch / 2), 0.0])
    qz = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
    return mul(qz, mul(qy, qx))


def body_rates(t: np.ndarray) -> np.ndarray:
    """The vehicle's rates: a first-order lag (TAU) of the rate setpoints, exact for the
    setpoint held between gyro samples, plus white gyro noise (σ 0.01 rad/s)."""
    sp = rate_setpoints(t)
    out = np.zeros_like(sp)
    for k in range(1, len(t)):
        a = np.exp(-(t[k] - t[k - 1]) / TAU)
        out[k] = a * out[k - 1] + (1 - a) * sp[k - 1]
    return out + np.random.default_rng(5).normal(scale=0.01, size=out.shape)


def write_highrate_ulog(path: Path) -> Path:
    names = list(FORMATS)
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", T0_US))
    out += _message(b"B", bytes(16) + bytes(24))
    out += b"".join(_message(b"F", _format_text(n)) for n in names)
    out += b"".join(_message(b"A", struct.pack("<BH", 0, i) + n.encode())
                    for i, n in enumerate(names))
    gyro_t = np.arange(0.0, DURATION, 1.0 / RATES["sensor_gyro"])
    rates = body_rates(gyro_t)
    records: list[tuple[int, bytes]] = []
    for i, name in enumerate(names):
        t = np.arange(0.0, DURATION, 1.0 / RATES[name])
        for k, tk in enumerate(t):
            us = T0_US + round(tk * 1e6)
            if name == "sensor_gyro":
                v: dict[str, object] = dict(zip("xyz", rates[k].tolist(), strict=True))
            elif name == "sensor_accel":
                v = {"x": 0.3, "y": -0.2, "z": -9.81}
            elif name == "sensor_combined":
                j = min(int(np.searchsorted(gyro_t, tk)), len(gyro_t) - 1)
                v = {"gyro_rad": rates[j].tolist(), "accelerometer_m_s2": [0.0, 0.0, -9.8]}
            elif name == "vehicle_rates_setpoint":
                sp = rate_setpoints(np.array([tk]))[0]
                v = {"roll": sp[0], "pitch": sp[1], "yaw": sp[2],
                     "thrust": 0.55 + 0.05 * np.sin(2 * np.pi * 0.1 * tk)}
            else:
                att = attitude_setpoint(np.array([tk]))[0]
                v = {"roll_body": att[0], "pitch_body": att[1], "yaw_body": att[2],
                     "q_d": _quat(*att).tolist(), "thrust": 0.55, "q_d_valid": True}
            v["timestamp"] = us
            records.append((us, _message(b"D", struct.pack("<H", i) + _pack(name, v))))
    records.sort(key=lambda r: r[0])
    out += b"".join(r[1] for r in records)
    path.write_bytes(bytes(out))
    return path


@pytest.fixture(scope="module")
def highrate(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_highrate_ulog(tmp_path_factory.mktemp("px4") / "highrate.ulg")


def test_sensor_gyro_at_full_rate_wins(highrate: Path) -> None:
    table = read_log(highrate)
    mapping = table.attrs["mapping"]
    assert [mapping[c] for c in "pqr"] == ["sensor_gyro.x", "sensor_gyro.y", "sensor_gyro.z"]
    assert [mapping[c] for c in ("ax", "ay", "az")] == ["sensor_accel.x", "sensor_accel.y",
                                                      "sensor_accel.z"]
    assert table.attrs["rate_hz"] == pytest.approx(205.0, rel=0.01)
    # the table's p is the gyro's p: compare on the gyro's own sample times
    gyro_t = np.arange(0.0, DURATION, 1.0 / 205.0)
    truth = body_rates(gyro_t)
    t = table.index.to_numpy()
    for i, c in enumerate("pqr"):
        np.testing.assert_allclose(table[c].to_numpy(),
                                   np.interp(t, gyro_t - gyro_t[0], truth[:, i]), atol=2e-3)
    assert table["az"].dropna().to_numpy() == pytest.approx(-9.81, abs=1e-5)


def test_setpoints_and_thrust_are_filled(highrate: Path) -> None:
    table = read_log(highrate)
    mapping = table.attrs["mapping"]
    assert mapping["sp_p"] == "vehicle_rates_setpoint.roll"
    assert mapping["sp_roll"] == "vehicle_attitude_setpoint.q_d"
    assert mapping["u_thrust"] == "vehicle_rates_setpoint.thrust"  # the faster setpoint
    t = table.index.to_numpy()
    # setpoints are held (zero-order hold): compare at the setpoints' own sample times
    at = np.arange(0.0, DURATION - 0.1, 1.0 / 50.0)
    rows = np.searchsorted(t, at + 1e-6)
    want = attitude_setpoint(at)
    for i, c in enumerate(("sp_roll", "sp_pitch", "sp_yaw")):
        np.testing.assert_allclose(table[c].to_numpy()[rows], want[:, i], atol=1e-5)
    thrust = table["u_thrust"].dropna().to_numpy()
    assert thrust.min() == pytest.approx(0.50, abs=2e-3)
    assert thrust.max() == pytest.approx(0.60, abs=2e-3)


def test_identify_runs_on_the_high_rate_log(highrate: Path) -> None:
    table = load_for_ident(highrate)
    assert table.attrs["input_selection"]["kind"] == "setpoints"
    run = identify(table, IdentConfig(), source=highrate)
    m = run.metrics
    assert m["sample_rate"]["native_rate_hz"] == pytest.approx(205.0, rel=0.01)
    assert m["flight"]["method"] == "rule (thrust)"  # no land detector: thrust 0.5–0.6
    for y in ("p", "q", "r"):
        out = m["outputs"][y]
        assert out["validation"]["one_step"]["rmse"] < out["persistence"]["validation"]["rmse"]
        assert out["validation"]["free_run"]["fit"] > 50.0
