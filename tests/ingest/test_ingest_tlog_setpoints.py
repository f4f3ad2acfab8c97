"""MAVLink ATTITUDE_TARGET (pymavlink-written tlog): its quaternion gives the attitude
setpoints sp_roll/sp_pitch/sp_yaw, its thrust a u_thrust of lower priority than the pilot's
measured RC throttle."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import common

from etsid.frames import euler_to_quat
from etsid.ingest import read_log, read_raw

START = 1.7e9


def _setpoint(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Known attitude setpoints, rad (yaw sweeping through ±π)."""
    return 0.3 * np.sin(2 * t), -0.2 * np.cos(1.5 * t), np.angle(np.exp(1j * (0.8 * t + 2.5)))


def write_tlog(path: Path, rc: bool, duration: float = 10.0) -> Path:
    """ATTITUDE and ATTITUDE_TARGET at 50 Hz; RC_CHANNELS throttle at 1500 µs if ``rc``.
    ATTITUDE_TARGET ignores the attitude (type_mask bit 128) for 4 ≤ t < 5 s."""
    mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
    out = bytearray()
    tt = np.arange(0.0, duration, 0.02)
    roll, pitch, yaw = _setpoint(tt)
    quat = np.stack(euler_to_quat(roll, pitch, yaw))
    for k, t in enumerate(tt):
        ms = int(1e3 * (t + 30.0))
        mask = 7 | (128 if 4.0 <= t < 5.0 else 0)  # body rates ignored
        frames = [mav.attitude_encode(ms, 0.0, 0.0, 0.0, 0.1 * np.sin(t), 0.0, 0.0),
                  mav.attitude_target_encode(ms, mask, [float(q) for q in quat[:, k]],
                                             0.0, 0.0, 0.0, 0.25 + 0.01 * t)]
        if rc:
            frames.append(mav.rc_channels_encode(ms, 8, 1500, 1500, 1700, 1500,
                                                 *([65535] * 14), 200))
        for msg in frames:
            out += struct.pack(">Q", int((START + t + 0.002) * 1e6)) + msg.pack(mav)
    path.write_bytes(bytes(out))
    return path


def test_attitude_target_quaternion_gives_attitude_setpoints(tmp_path: Path) -> None:
    table = read_log(write_tlog(tmp_path / "sp.tlog", rc=True))
    for column in ("sp_roll", "sp_pitch", "sp_yaw"):
        assert table.attrs["mapping"][column] == "ATTITUDE_TARGET.q"
    tt = table.index.to_numpy()
    truth = _setpoint(tt)
    ignored = (tt > 4.0) & (tt < 4.98)
    for column, want in zip(("sp_roll", "sp_pitch", "sp_yaw"), truth, strict=True):
        got = table[column].to_numpy()
        assert np.isnan(got[ignored]).all(), column  # type_mask: no attitude setpoint
        ok = np.isfinite(got)
        assert ok.sum() > 0.85 * tt.size
        err = np.angle(np.exp(1j * (got[ok] - want[ok])))
        # exact at the setpoint's own times; a few grid points hold the previous one (≤ 0.016 rad)
        assert np.median(np.abs(err)) < 1e-6 and np.abs(err).max() < 0.02, column
    # the measured attitude is not touched by the setpoint
    np.testing.assert_allclose(table["roll"], 0.0, atol=1e-7)


def test_attitude_target_thrust_is_below_the_measured_throttle(tmp_path: Path) -> None:
    with_rc = read_log(write_tlog(tmp_path / "rc.tlog", rc=True))
    assert with_rc.attrs["mapping"]["u_thrust"] == "RC_CHANNELS.chan3_raw"
    np.testing.assert_allclose(with_rc["u_thrust"].dropna(), 0.7, atol=1e-9)
    raw = read_raw(tmp_path / "rc.tlog")
    thrusts = {s.source: s.priority for s in raw.signals if s.column == "u_thrust"}
    assert thrusts["ATTITUDE_TARGET.thrust"] > thrusts["RC_CHANNELS.chan3_raw"]
    alone = read_log(write_tlog(tmp_path / "norc.tlog", rc=False))
    assert alone.attrs["mapping"]["u_thrust"] == "ATTITUDE_TARGET.thrust"
    tt = alone.index.to_numpy()
    np.testing.assert_allclose(alone["u_thrust"], 0.25 + 0.01 * tt, atol=2.5e-4)


@pytest.mark.parametrize("bad", [(0.0, 0.0, 0.0, 0.0)])
def test_zero_quaternion_is_no_setpoint(tmp_path: Path, bad: tuple[float, ...]) -> None:
    mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
    out = bytearray()
    for k in range(100):
        t = k * 0.02
        ms = int(1e3 * (t + 30.0))
        for msg in (mav.attitude_encode(ms, 0, 0, 0, 0.1, 0, 0),
                    mav.attitude_target_encode(ms, 7, list(bad), 0, 0, 0, 0.5)):
            out += struct.pack(">Q", int((START + t) * 1e6)) + msg.pack(mav)
    (tmp_path / "z.tlog").write_bytes(bytes(out))
    assert "sp_roll" not in read_log(tmp_path / "z.tlog").columns
