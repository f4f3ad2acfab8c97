"""Write a FlightTable as a MAVLink telemetry log (``.tlog``), as a Pixhawk streams it.

Frames are encoded by pymavlink's own MAVLink 2 encoder (``pymavlink.dialects.v20.common``)
and written through a file-like sink that puts the 8-byte big-endian ground-station
receive time (µs since the Unix epoch) in front of each, exactly as ground stations do.
Each message stream runs at its own rate (:data:`RATES`), sampled from the table (linear
interpolation for continuous columns, hold for commands). The receive time is the send
time plus a seeded random link delay (a few ms, with occasional stalls of up to 0.3 s
that release queued frames in a burst); the link is FIFO, so frames stay in send order.
Only streams whose columns the table has are written; HEARTBEAT always is.

Inverse of :mod:`etsid.ingest.mavlink.tlog`: sticks and motors → PWM through :mod:`etsid.pwm`
(default range: sticks 1500 ± 500 µs, throttle and motors 1000…2000 µs), alt →
DISTANCE_SENSOR cm (orientation 25, downward) and LOCAL_POSITION_NED −z, vbat → SYS_STATUS
mV. NaN in an integer field becomes the field's
"unknown" value (UINT16_MAX for RC channels and voltage, 0 for servo outputs).
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
import pandas as pd

from etsid.pwm import (
    DEFAULT_RC_MAP,
    DEFAULT_RC_RANGE_US,
    UNUSED,
    RcRange,
    motor_to_pwm,
    stick_to_pwm,
)
from etsid.table import COLUMNS

RATES: dict[str, float] = {
    "ATTITUDE": 50.0,
    "HIGHRES_IMU": 100.0,
    "RC_CHANNELS": 25.0,
    "SERVO_OUTPUT_RAW": 25.0,
    "ATTITUDE_TARGET": 25.0,
    "DISTANCE_SENSOR": 20.0,
    "LOCAL_POSITION_NED": 30.0,
    "SYS_STATUS": 2.0,
    "HEARTBEAT": 1.0,
}
"""Default stream rates, Hz (override per message with ``rates=``)."""

BOOT_OFFSET_S = 30.0
"""Autopilot uptime at the table's t = 0 (the log starts mid-boot, as real ones do)."""
DEFAULT_START = 1.7e9


class _StampedSink:
    """File-like sink for ``pymavlink``'s ``MAVLink.send``: prefixes the receive stamp."""

    def __init__(self, handle: BinaryIO) -> None:
        self.handle = handle
        self.stamp_us = 0

    def write(self, buf: bytes) -> None:
        self.handle.write(struct.pack(">Q", self.stamp_us) + bytes(buf))


def _column(table: pd.DataFrame, name: str, t: np.ndarray) -> np.ndarray | None:
    if name not in table.columns:
        return None
    src_t = np.asarray(table.index, dtype=float)
    v = table[name].to_numpy(dtype=float)
    if COLUMNS.get(name) is not None and COLUMNS[name].interp == "hold":
        idx = np.clip(np.searchsorted(src_t, t, side="right") - 1, 0, v.size - 1)
        return v[idx]
    if COLUMNS.get(name) is not None and COLUMNS[name].interp == "angle":
        ok = np.isfinite(v)
        out = np.interp(t, src_t[ok], np.unwrap(v[ok])) if ok.any() else np.full(t.size, np.nan)
        out = np.angle(np.exp(1j * out))
        return _nan_where_source_nan(out, src_t, v, t)
    ok = np.isfinite(v)
    out = np.interp(t, src_t[ok], v[ok]) if ok.any() else np.full(t.size, np.nan)
    return _nan_where_source_nan(out, src_t, v, t)


def _nan_where_source_nan(out: np.ndarray, src_t: np.ndarray, v: np.ndarray,
                          t: np.ndarray) -> np.ndarray:
    idx = np.clip(np.searchsorted(src_t, t), 0, v.size - 1)
    out = out.copy()
    bad = ~np.isfinite(v[idx])
    out[bad] = v[idx][bad]  # keeps NaN and ±inf of the table visible in the log
    return out


def _u16(x: np.ndarray, missing: int) -> np.ndarray:
    out = np.full(x.shape, missing, dtype=np.int64)
    ok = np.isfinite(x)
    out[ok] = np.clip(np.rint(x[ok]), 0, 65535 if missing != 65535 else 65534)
    return out


def _link_delay(send: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Receive times (s) for frames sent at ``send`` (sorted) over a FIFO link with stalls."""
    recv = send + 0.004 + rng.exponential(0.006, send.size)
    span = send[-1] - send[0] if send.size else 0.0
    n_stalls = rng.poisson(0.3 * span) if span > 0 else 0
    for start in rng.uniform(send[0], send[-1], n_stalls) if n_stalls else ():
        end = start + rng.uniform(0.05, 0.3)
        inside = (send >= start) & (send < end)
        recv[inside] = np.maximum(recv[inside], end + rng.uniform(0.0, 0.01))
    return np.maximum.accumulate(recv)


def _streams(table: pd.DataFrame, rates: dict[str, float]) -> dict[str, np.ndarray]:
    have = set(table.columns)
    streams = {"HEARTBEAT": True,
               "ATTITUDE": bool(have & {"p", "q", "r", "roll", "pitch", "yaw"}),
               "HIGHRES_IMU": bool(have & {"ax", "ay", "az"}),
               "RC_CHANNELS": bool(have & {"u_roll", "u_pitch", "u_thrust", "u_yaw"}),
               "SERVO_OUTPUT_RAW": bool(have & {f"m{i}" for i in range(1, 9)}),
               "ATTITUDE_TARGET": bool(have & {"sp_p", "sp_q", "sp_r"}),
               "DISTANCE_SENSOR": "alt" in have,
               "LOCAL_POSITION_NED": bool(have & {"vx", "vy", "vz", "alt"}),
               "SYS_STATUS": "vbat" in have}
    t = np.asarray(table.index, dtype=float)
    out = {}
    for name, on in streams.items():
        if on and rates.get(name, 0) > 0:
            out[name] = np.arange(t[0], t[-1] + 1e-9, 1.0 / rates[name])
    return out


def _encoders(table: pd.DataFrame, mav: Any, t: dict[str, np.ndarray], rc_map: dict[str, int],
              rc_range_us: RcRange) -> dict[str, Callable[[int], Any]]:
    """Message name → function(sample index) → pymavlink message."""
    col = {name: {c: _column(table, c, ts) for c in table.columns if c in COLUMNS}
           for name, ts in t.items()}
    zero = {name: np.zeros(ts.size) for name, ts in t.items()}

    def g(name: str, c: str, default: float = 0.0) -> np.ndarray:
        v = col[name].get(c)
        return zero[name] + default if v is None else v

    def boot_ms(name: str) -> np.ndarray:
        return np.rint((t[name] + BOOT_OFFSET_S) * 1e3).astype(np.int64)

    enc: dict[str, Callable[[int], Any]] = {}
    if "HEARTBEAT" in t:
        enc["HEARTBEAT"] = lambda i: mav.heartbeat_encode(13, 3, 81, 0, 4)
    if "ATTITUDE" in t:
        a = [g("ATTITUDE", c) for c in ("roll", "pitch", "yaw", "p", "q", "r")]
        ms = boot_ms("ATTITUDE")
        enc["ATTITUDE"] = lambda i, ms=ms: mav.attitude_encode(
            int(ms[i]), *(float(x[i]) for x in a))
    if "HIGHRES_IMU" in t:
        acc = [g("HIGHRES_IMU", c) for c in ("ax", "ay", "az")]
        gyr = [g("HIGHRES_IMU", c) for c in ("p", "q", "r")]
        us = np.rint((t["HIGHRES_IMU"] + BOOT_OFFSET_S) * 1e6).astype(np.int64)
        enc["HIGHRES_IMU"] = lambda i: mav.highres_imu_encode(
            int(us[i]), *(float(x[i]) for x in acc), *(float(x[i]) for x in gyr),
            0.0, 0.0, 0.0, 1013.0, 0.0, 0.0, 25.0, 0x3F)
    if "RC_CHANNELS" in t:
        nchan = max(8, *rc_map.values())
        chans = np.full((nchan, t["RC_CHANNELS"].size), 65535, dtype=np.int64)
        for stick, ch in rc_map.items():
            v = col["RC_CHANNELS"].get(stick)
            if v is not None:
                chans[ch - 1] = _u16(stick_to_pwm(v, stick, rc_range_us), UNUSED)
        ms = boot_ms("RC_CHANNELS")
        enc["RC_CHANNELS"] = lambda i, ms=ms: mav.rc_channels_encode(
            int(ms[i]), nchan, *(int(c) for c in chans[:, i]), *([65535] * (18 - nchan)), 200)
    if "SERVO_OUTPUT_RAW" in t:
        servos = [_u16(motor_to_pwm(g("SERVO_OUTPUT_RAW", f"m{k}", np.nan), rc_range_us), 0)
                  for k in range(1, 9)]
        us32 = np.rint((t["SERVO_OUTPUT_RAW"] + BOOT_OFFSET_S) * 1e6).astype(np.int64) % 2**32
        enc["SERVO_OUTPUT_RAW"] = lambda i: mav.servo_output_raw_encode(
            int(us32[i]), 0, *(int(s[i]) for s in servos))
    if "ATTITUDE_TARGET" in t:
        enc["ATTITUDE_TARGET"] = _attitude_target(mav, t["ATTITUDE_TARGET"],
                                                  col["ATTITUDE_TARGET"], boot_ms)
    if "DISTANCE_SENSOR" in t:
        cm = _u16(100.0 * g("DISTANCE_SENSOR", "alt"), 65535)
        ms = boot_ms("DISTANCE_SENSOR")
        enc["DISTANCE_SENSOR"] = lambda i, ms=ms: mav.distance_sensor_encode(
            int(ms[i]), 1, 4000, int(cm[i]), 0, 0, 25, 255)
    if "LOCAL_POSITION_NED" in t:
        ts = t["LOCAL_POSITION_NED"]
        v = [g("LOCAL_POSITION_NED", c) for c in ("vx", "vy", "vz")]
        dt = np.diff(ts, prepend=ts[0])
        x, y = (np.cumsum(np.nan_to_num(vv) * dt) for vv in v[:2])
        z = -g("LOCAL_POSITION_NED", "alt") if "alt" in table.columns else \
            np.cumsum(np.nan_to_num(v[2]) * dt)
        ms = boot_ms("LOCAL_POSITION_NED")
        enc["LOCAL_POSITION_NED"] = lambda i, ms=ms: mav.local_position_ned_encode(
            int(ms[i]), float(x[i]), float(y[i]), float(z[i]), *(float(c[i]) for c in v))
    if "SYS_STATUS" in t:
        mv = _u16(1000.0 * g("SYS_STATUS", "vbat", np.nan), 65535)
        enc["SYS_STATUS"] = lambda i: mav.sys_status_encode(
            0, 0, 0, 500, int(mv[i]), -1, -1, 0, 0, 0, 0, 0, 0)
    return enc


def _attitude_target(mav: Any, ts: np.ndarray, col: dict[str, np.ndarray | None],
                     boot_ms: Callable[[str], np.ndarray]) -> Callable[[int], Any]:
    from etsid.frames import euler_to_quat

    zero = np.zeros(ts.size)
    rates = [col.get(c) for c in ("sp_p", "sp_q", "sp_r")]
    thrust = col.get("u_thrust")
    mask = sum(bit for bit, v in zip((1, 2, 4), rates, strict=True) if v is None)
    mask |= 64 if thrust is None else 0
    att = [col.get(c) for c in ("roll", "pitch", "yaw")]
    mask |= 128 if all(a is None for a in att) else 0
    quat = np.stack(euler_to_quat(*(zero if a is None else np.nan_to_num(a) for a in att)))
    rates = [zero if v is None else v for v in rates]
    thrust = zero if thrust is None else thrust
    ms = boot_ms("ATTITUDE_TARGET")
    return lambda i: mav.attitude_target_encode(
        int(ms[i]), mask, [float(q) for q in quat[:, i]], *(float(r[i]) for r in rates),
        float(thrust[i]))


def write_tlog(table: pd.DataFrame, path: str | Path, sysid: int = 1, compid: int = 1,
               rates: dict[str, float] | None = None, seed: int = 0,
               rc_map: dict[str, int] | None = None,
               rc_range_us: RcRange = DEFAULT_RC_RANGE_US) -> Path:
    """Write ``table`` (a FlightTable) as a MAVLink 2 telemetry log.

    Parameters
    ----------
    table
        FlightTable; ``table.attrs["start_time"]`` (Unix s of t = 0, default 1.7e9) sets
        the ground-station clock.
    rates
        Per-message stream rate overrides, Hz (0 drops a stream); see :data:`RATES`.
    seed
        Seed of the random link delay.
    rc_map
        Stick → RC channel (1-based), default ArduPilot AETR (1 roll, 2 pitch, 3 throttle,
        4 yaw).
    rc_range_us
        PWM min, centre, max, µs, for sticks and motors (:mod:`etsid.pwm`; not clipped, so
        sticks beyond ±1 give PWM beyond the range).

    Returns
    -------
    Path
        ``path``.
    """
    from pymavlink.dialects.v20 import common

    path = Path(path)
    rates = {**RATES, **(rates or {})}
    start = table.attrs.get("start_time") or DEFAULT_START
    t = _streams(table, rates)
    rng = np.random.default_rng(seed)
    with path.open("wb") as handle:
        sink = _StampedSink(handle)
        mav = common.MAVLink(sink, srcSystem=sysid, srcComponent=compid)
        enc = _encoders(table, mav, t, dict(rc_map or DEFAULT_RC_MAP), rc_range_us)
        names = list(t)
        send = np.concatenate([t[n] for n in names]) if names else np.empty(0)
        which = np.concatenate([np.full(t[n].size, k) for k, n in enumerate(names)])
        index = np.concatenate([np.arange(t[n].size) for n in names])
        order = np.lexsort((which, send))
        recv = _link_delay(send[order], rng)
        stamps = np.rint((start + recv) * 1e6).astype(np.int64)
        for j, o in enumerate(order):
            sink.stamp_us = int(stamps[j])
            mav.send(enc[names[which[o]]](int(index[o])))
    return path
