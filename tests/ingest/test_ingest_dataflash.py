"""ArduPilot DataFlash logs: real truncated log, hand-built logs, bad input."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from pymavlink import DFReader

from etsid.cli import cli
from etsid.errors import IngestError
from etsid.ingest import read_log, read_raw
from etsid.ingest.base import Override, ReadOptions

DATA = Path(__file__).parents[1] / "data"
BIN = DATA / "arduplane_truncated.BIN"
HEAD = b"\xa3\x95"
_STRUCT = {"Q": "Q", "f": "f", "H": "H", "B": "B", "h": "h", "C": "H"}


def _fmt_msg(mtype: int, name: str, fmt: str, columns: str) -> bytes:
    length = 3 + struct.calcsize("<" + "".join(_STRUCT[c] for c in fmt))
    body = struct.pack("<BB4s16s64s", mtype, length, name.encode(), fmt.encode(),
                       columns.encode())
    return HEAD + bytes([0x80]) + body


def _msg(mtype: int, fmt: str, *values: float) -> bytes:
    return HEAD + bytes([mtype]) + struct.pack("<" + "".join(_STRUCT[c] for c in fmt), *values)


def write_small_bin(path: Path, rfnd_fmt: str = "QH") -> Path:
    """A DataFlash log with RATE (400 Hz), RCIN, RFND and BAT, made byte by byte."""
    out = bytearray()
    out += _fmt_msg(130, "RATE", "Qffffffffffff",
                    "TimeUS,RDes,R,ROut,PDes,P,POut,YDes,Y,YOut,ADes,A,AOut")
    out += _fmt_msg(131, "RCIN", "QHHHH", "TimeUS,C1,C2,C3,C4")
    out += _fmt_msg(132, "RFND", rfnd_fmt, "TimeUS,Dist1")
    out += _fmt_msg(133, "BAT", "Qf", "TimeUS,Volt")
    for k in range(800):
        t = k / 400.0
        us = int(1e6 * (10.0 + t))
        deg = 30.0 * np.sin(2 * np.pi * t)
        out += _msg(130, "Qffffffffffff", us, deg + 1, deg, 0.1, 0, 0, 0.2, 0, 0, 0.3, 0, 0, 0.5)
        if k % 16 == 0:
            out += _msg(131, "QHHHH", us, 1500 + k // 2, 1500, 1000 + k, 1500)
        if k % 20 == 0:
            dist = 150.0 + k / 10  # cm for 'QH', m*100 for 'QC'
            out += _msg(132, rfnd_fmt, us, int(dist))
        if k % 40 == 0:
            out += _msg(133, "Qf", us, 16.0 - t)
    path.write_bytes(bytes(out))
    return path


def test_real_truncated_log_valid_part_and_warning() -> None:
    out = read_log(BIN)
    assert any("truncated" in w and "24 bytes" in w for w in out.attrs["warnings"])
    assert out.index[-1] == pytest.approx(0.96, abs=0.05)
    assert {"p", "roll", "u_roll", "m1", "vbat", "ax"} <= set(out.columns)
    assert out.attrs["mapping"]["p"] == "IMU.GyrX"
    assert out.attrs["start_time"] == pytest.approx(1509241548, abs=86400)  # 2017-10-29


def test_real_log_values_match_dfreader() -> None:
    raw = read_raw(BIN)
    sig = {s.source: s for s in raw.signals}
    df = DFReader.DFReader_binary(str(BIN))
    att, imu = [], []
    while (m := df.recv_match(type=["ATT", "IMU"])) is not None:
        (att if m.get_type() == "ATT" else imu).append(m)
    np.testing.assert_allclose(sig["ATT.Roll"].values, [np.radians(m.Roll) for m in att],
                               rtol=1e-6)
    np.testing.assert_allclose(sig["ATT.Roll"].t, [m.TimeUS * 1e-6 for m in att])
    np.testing.assert_allclose(sig["IMU.GyrX"].values, [m.GyrX for m in imu], rtol=1e-6)
    yaw = sig["ATT.Yaw"].values
    assert np.all(np.abs(yaw) <= np.pi)
    rates = {c.name: c.rate_hz for c in raw.channels}
    assert rates["IMU"] == pytest.approx(45, abs=2)


def test_hand_built_log_rate_rcin_rfnd_bat(tmp_path: Path) -> None:
    raw = read_raw(write_small_bin(tmp_path / "small.bin"))
    sig = {s.source: s for s in raw.signals}
    p = sig["RATE.R"]
    assert p.column == "p" and p.priority == 0
    t = np.arange(800) / 400.0
    np.testing.assert_allclose(p.values, np.radians(30 * np.sin(2 * np.pi * t)), atol=1e-6)
    np.testing.assert_allclose(sig["RATE.RDes"].values - p.values, np.radians(1.0), atol=1e-6)
    assert sig["RATE.ROut"].column == "u_roll" and sig["RATE.ROut"].priority == 5
    assert sig["RATE.AOut"].column == "u_thrust"
    np.testing.assert_allclose(sig["RFND.Dist1"].values[:3], [1.5, 1.52, 1.54])  # cm -> m
    np.testing.assert_allclose(sig["BAT.Volt"].values[:2], [16.0, 15.9], rtol=1e-6)
    assert sig["RCIN.C3"].column == "u_thrust"
    np.testing.assert_allclose(sig["RCIN.C3"].values[:2], [0.0, 0.016])
    out = read_log(tmp_path / "small.bin")
    assert out.attrs["rate_hz"] == pytest.approx(400.0)
    assert out.attrs["mapping"]["u_roll"] == "RCIN.C1"


def test_rfnd_scaled_format_is_metres(tmp_path: Path) -> None:
    raw = read_raw(write_small_bin(tmp_path / "c.bin", rfnd_fmt="QC"))
    alt = next(s for s in raw.signals if s.column == "alt")
    np.testing.assert_allclose(alt.values[:2], [1.5, 1.52])  # 'C' = uint16 * 0.01


def test_override_field(tmp_path: Path) -> None:
    path = write_small_bin(tmp_path / "o.bin")
    out = read_log(path, ReadOptions(overrides=[Override("p", "RATE", "RDes")]))
    assert out.attrs["mapping"]["p"] == "RATE.RDes"
    with pytest.raises(IngestError, match="no such field"):
        read_log(path, ReadOptions(overrides=[Override("p", "RATE", "Nope")]))


def test_truncated_mid_message(tmp_path: Path) -> None:
    path = write_small_bin(tmp_path / "cut.bin")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - 30])
    out = read_log(path)
    assert any("truncated" in w for w in out.attrs["warnings"])
    assert out.index[-1] == pytest.approx(1.9975, abs=0.01)


def test_no_usable_messages(tmp_path: Path) -> None:
    path = tmp_path / "fmt_only.bin"
    path.write_bytes(_fmt_msg(140, "XYZ", "QH", "TimeUS,V") + _msg(140, "QH", 1, 2)
                     + _msg(140, "QH", 2, 3))
    with pytest.raises(IngestError, match="no usable flight data; found .*XYZ"):
        read_log(path)


@pytest.mark.parametrize(("content", "match"), [
    (b"", "empty file"),
    (HEAD + bytes(range(7, 250)) * 8, "no DataFlash messages found"),
    (b"definitely not dataflash", "not an ArduPilot DataFlash log"),
])
def test_bad_files(tmp_path: Path, content: bytes, match: str) -> None:
    path = tmp_path / "bad.bin"
    path.write_bytes(content)
    with pytest.raises(IngestError, match=match):
        read_log(path)
    result = CliRunner().invoke(cli, ["ingest", str(path), "-o", str(tmp_path / "o.parquet")])
    assert result.exit_code == 1
    assert "Traceback" not in result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and match in lines[0] and str(path) in lines[0]


PWM_IN = (1000, 1750, 1250, 2100)
"""RCIN C1…C4 (AETR: u_roll, u_pitch, u_thrust, u_yaw), µs."""
PWM_OUT = (1000, 1500, 2050, 1900, 0)
"""RCOU C1…C5, µs (C5 0: output not used)."""


def write_pwm_bin(path: Path) -> Path:
    """RATE (so the log has flight data) and RCIN/RCOU at constant known PWM, 50 Hz."""
    out = bytearray()
    out += _fmt_msg(130, "RATE", "Qfff", "TimeUS,R,P,Y")
    out += _fmt_msg(131, "RCIN", "QHHHH", "TimeUS,C1,C2,C3,C4")
    out += _fmt_msg(134, "RCOU", "QHHHHH", "TimeUS,C1,C2,C3,C4,C5")
    for k in range(100):
        us = int(1e6 * (10.0 + k / 50.0))
        out += _msg(130, "Qfff", us, 0.0, 0.0, 0.0)
        out += _msg(131, "QHHHH", us, *PWM_IN)
        out += _msg(134, "QHHHHH", us, *PWM_OUT)
    path.write_bytes(bytes(out))
    return path


@pytest.mark.parametrize(("rc_range", "sticks", "motors", "clipped"), [
    ((1000.0, 1500.0, 2000.0), (-1.0, 0.5, 0.25, 1.0), (0.0, 0.5, 1.0, 0.9),
     {"RCIN.C4", "RCOU.C3"}),
    ((1100.0, 1500.0, 1900.0), (-1.0, 0.625, 0.1875, 1.0), (0.0, 0.5, 1.0, 1.0),
     {"RCIN.C1", "RCIN.C4", "RCOU.C1", "RCOU.C3"}),
])
def test_rc_and_motor_pwm_use_the_configured_range(
        tmp_path: Path, rc_range: tuple[float, float, float], sticks: tuple[float, ...],
        motors: tuple[float, ...], clipped: set[str]) -> None:
    raw = read_raw(write_pwm_bin(tmp_path / "pwm.bin"), ReadOptions(rc_range_us=rc_range))
    sig = {s.source: s for s in raw.signals}
    for ch, (column, want) in enumerate(zip(("u_roll", "u_pitch", "u_thrust", "u_yaw"), sticks,
                                            strict=True), start=1):
        assert sig[f"RCIN.C{ch}"].column == column
        np.testing.assert_allclose(sig[f"RCIN.C{ch}"].values, want, atol=1e-12)
    for ch, want in enumerate(motors, start=1):
        np.testing.assert_allclose(sig[f"RCOU.C{ch}"].values, want, atol=1e-12)
    assert "RCOU.C5" not in sig  # all 0: not an output
    counts = {i.signal: i.count for i in raw.repaired if "PWM outside" in i.reason}
    assert counts == dict.fromkeys(clipped, 100)


def _gps_reports(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(time s, Status, Spd m/s, VZ m/s) of every GPS report, read with DFReader; 3.x logs
    time GPS by boot milliseconds in ``T``."""
    df = DFReader.DFReader_binary(str(path))
    rows = []
    while (m := df.recv_match(type=["GPS"])) is not None:
        t = m.TimeUS * 1e-6 if hasattr(m, "TimeUS") else m.T * 1e-3
        rows.append((t, m.Status, m.Spd, m.VZ))
    return tuple(np.array(c, dtype=float) for c in zip(*rows, strict=True))  # type: ignore[return-value]


@pytest.mark.parametrize(("name", "source", "speed_corr"), [
    ("ardupilot_copter403_hexa_loiter_real.bin", "NKF1", 0.5),
    ("ardupilot_copter33_loiter_acro_flips_real.bin", "EKF1", 0.9)])
def test_real_logs_velocity_is_the_ekfs_and_agrees_with_the_gps(name: str, source: str,
                                                               speed_corr: float) -> None:
    """The EKF's NED velocity against an independent sensor, the GPS receiver's own
    ground speed; horizontal velocity only where the GPS had a 3D fix."""
    raw = read_raw(DATA / name)
    by_column = {s.column: s for s in raw.signals if s.column in ("vx", "vy", "vz")}
    assert [by_column[c].source for c in ("vx", "vy", "vz")] == [
        f"{source}.VN", f"{source}.VE", f"{source}.VD"]
    t, status, speed, _ = _gps_reports(DATA / name)
    fixed = status >= 3
    vx, vy = by_column["vx"], by_column["vy"]
    vz = by_column["vz"]
    last = np.searchsorted(t, vz.t, side="right") - 1
    want_kept = (last >= 0) & (status[np.maximum(last, 0)] >= 3)
    assert np.array_equal(vx.t, vz.t[want_kept]) and np.array_equal(vy.t, vx.t)
    lost = [i.count for i in raw.dropped if i.reason == "no GPS 3D fix"]
    assert lost == ([int(np.sum(~want_kept))] * 2 if not want_kept.all() else [])
    ok = np.isfinite(vx.values)
    ekf_speed = np.hypot(np.interp(t[fixed], vx.t[ok], vx.values[ok]),
                         np.interp(t[fixed], vy.t[ok], vy.values[ok]))
    assert np.median(np.abs(ekf_speed - speed[fixed])) < 0.2
    assert np.corrcoef(ekf_speed, speed[fixed])[0, 1] > speed_corr
    table = read_log(DATA / name)
    assert table.attrs["mapping"]["vz"] == f"{source}.VD"


def test_hexacopter_climb_rate_follows_the_gps_vertical_velocity() -> None:
    name = DATA / "ardupilot_copter403_hexa_loiter_real.bin"
    vz = next(s for s in read_raw(name).signals if s.column == "vz")
    t, status, _, gps_vz = _gps_reports(name)
    ekf = np.interp(t[status >= 3], vz.t, vz.values)
    assert np.corrcoef(ekf, gps_vz[status >= 3])[0, 1] > 0.7  # both NED: down positive
    assert np.median(np.abs(ekf - gps_vz[status >= 3])) < 0.15


def test_ekf3_velocity_keeps_core_zero_and_no_gps_keeps_vz_only(tmp_path: Path) -> None:
    """XKF1 logs one record per EKF core (``C``); without a GPS fix the horizontal velocity
    of a constant-position EKF is no measurement."""
    out = bytearray(_fmt_msg(140, "XKF1", "QBfff", "TimeUS,C,VN,VE,VD"))
    for k in range(100):
        us = int(1e6 * (5.0 + k / 10.0))
        for core in (0, 1):
            out += _msg(140, "QBfff", us, core, 1.0 + core, 2.0 + core, -0.5 - k / 100 - core)
    path = tmp_path / "xkf.bin"
    path.write_bytes(bytes(out))
    raw = read_raw(path)
    cols = {s.column: s for s in raw.signals if s.column in ("vx", "vy", "vz")}
    assert set(cols) == {"vz"}
    assert cols["vz"].source == "XKF1.VD" and cols["vz"].t.size == 100
    np.testing.assert_allclose(cols["vz"].values, -0.5 - np.arange(100) / 100, rtol=1e-6)
