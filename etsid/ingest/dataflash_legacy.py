"""What older ArduPilot DataFlash generations write differently (used by
:mod:`etsid.ingest.dataflash`).

- **Untimed messages**: in ArduCopter ≤ 3.3 ``EV`` (and ``ERR``) carry no ``TimeUS`` /
  ``TimeMS`` field. Each gets the time of the last timed message written before it in the
  file (:func:`file_times`): the logger writes in time order, so the event happened between
  that message and the next one (≤ one sample period of the fastest stream, 20 ms at
  50 Hz).
- **GPS time**: in those logs ``GPS.TimeMS`` is the GPS time of week (ms) and ``GPS.T`` the
  time since boot (:data:`BOOT_TIME_FIELDS`).
- **RATE units**: ``R P Y RDes PDes YDes`` are centidegrees/s in 3.x logs, degrees/s in
  4.x; the unit is decided by comparing ``RATE.R`` with the IMU gyro (:func:`rate_scale`).
  ``ROut POut YOut`` are ±4500 and ``AOut`` 0…1000 in 3.x, ±1 and 0…1 in 4.x
  (:func:`out_scales`).
- **Throttle**: ``CTUN.ThrOut`` is an int16 0…1000 up to 3.3; from 3.4 ``CTUN.ThO`` a float
  0…1 (:func:`ctun_throttle_scale`).
- **Events**: :mod:`etsid.ingest.dataflash` ``_landed`` (TAKEOFF 16 up to 3.2).
- **Altitude**: without a rangefinder the barometric height above the arming point,
  ``CTUN.BarAlt`` (3.x; ``BAlt`` in 4.x) or ``BARO.Alt`` (:func:`baro_altitude`).
"""

from __future__ import annotations

import numpy as np

BOOT_TIME_FIELDS = {"GPS": "T"}
"""Messages whose time since boot is in another field than TimeUS/TimeMS (ms)."""
RATE_UNITS = {"deg/s": np.pi / 180.0, "cdeg/s": np.pi / 18000.0}
"""Scale of RATE's rate fields to rad/s, by unit."""
OUT_3X = {"ROut": 4500.0, "POut": 4500.0, "YOut": 4500.0, "AOut": 1000.0}
"""Full-scale values of RATE's controller outputs in 3.x logs (4.x: ±1 and 0…1)."""


def _clock(reader: object, data: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(file offsets, times s) of the most frequent message type whose first field is
    ``TimeUS`` (uint64 µs) or ``TimeMS`` (uint32 ms), sorted by offset."""
    best = None
    for mtype, fmt in reader.formats.items():  # type: ignore[attr-defined]
        cols = list(getattr(fmt, "columns", []) or [])
        code = getattr(fmt, "msg_struct", "<")[1:2]
        if not cols or (cols[0], code) not in (("TimeUS", "Q"), ("TimeMS", "I")):
            continue
        offs = reader.offsets[mtype] if mtype < len(reader.offsets) else []  # type: ignore[attr-defined]
        if offs and (best is None or len(offs) > len(best[0])):
            best = (offs, cols[0])
    if best is None:
        return None
    offs = np.asarray(best[0], dtype=np.int64)
    width, scale, kind = (8, 1e-6, "<u8") if best[1] == "TimeUS" else (4, 1e-3, "<u4")
    offs = np.sort(offs[offs + 3 + width <= data.size])
    if not offs.size:
        return None
    raw = data[(offs + 3)[:, None] + np.arange(width)].copy().view(kind).ravel()
    return offs, np.maximum.accumulate(raw.astype(np.float64) * scale)


def file_times(reader: object, data: np.ndarray, offsets: np.ndarray) -> np.ndarray | None:
    """Times (s) of untimed messages at ``offsets``: the time of the last timed message
    before each in the file (the first timed one for messages before any); None when the
    log has no timed stream."""
    clock = _clock(reader, data)
    if clock is None:
        return None
    offs, times = clock
    i = np.clip(np.searchsorted(offs, np.asarray(offsets, dtype=np.int64)) - 1, 0, None)
    return times[i]


def rate_scale(rate_t: np.ndarray, rate_r: np.ndarray, imu_t: np.ndarray | None,
               imu_gx: np.ndarray | None) -> tuple[float, str]:
    """Scale of ``RATE.R`` to rad/s and its unit name: the unit of :data:`RATE_UNITS` whose
    values match the IMU's roll rate best (log of the ratio of the robust spreads); deg/s
    without an IMU (the 4.x unit)."""
    if imu_t is None or imu_gx is None or imu_t.size < 10 or rate_t.size < 10:
        return RATE_UNITS["deg/s"], "deg/s"
    gyro = np.interp(rate_t, imu_t, imu_gx)
    ok = np.isfinite(gyro) & np.isfinite(rate_r)
    spread_imu = np.median(np.abs(gyro[ok] - np.median(gyro[ok]))) if ok.any() else 0.0
    spread_rate = np.median(np.abs(rate_r[ok] - np.median(rate_r[ok]))) if ok.any() else 0.0
    if not (spread_imu > 0 and spread_rate > 0):
        return RATE_UNITS["deg/s"], "deg/s"
    unit = min(RATE_UNITS, key=lambda u: abs(np.log(spread_rate * RATE_UNITS[u] / spread_imu)))
    return RATE_UNITS[unit], unit


def out_scales(fields: dict[str, np.ndarray]) -> dict[str, float]:
    """Scale of each RATE controller output to the FlightTable's −1…1 (0…1 for AOut): 3.x
    full scales (:data:`OUT_3X`) when any output exceeds 1.5 in magnitude, else 1."""
    big = any(np.nanmax(np.abs(v), initial=0.0) > 1.5 for v in fields.values() if v.size)
    return {name: (1.0 / OUT_3X[name] if big else 1.0) for name in fields}


CTUN_THR_3X = 1000.0
"""Full scale of ``CTUN.ThrOut`` up to 3.3 (an int16 0…1000); ``ThO`` (3.4 on) is 0…1."""


def ctun_throttle_scale(thr_out: np.ndarray) -> float:
    """Scale of ``CTUN.ThrOut`` to 0…1: ``1/1000`` when any value exceeds 1.5 (3.x), else 1.

    >>> ctun_throttle_scale(np.array([0.0, 450.0]))
    0.001
    """
    big = np.nanmax(np.abs(thr_out), initial=0.0) > 1.5
    return 1.0 / CTUN_THR_3X if big else 1.0


def baro_altitude(ctun: object | None, baro: object | None) -> list[tuple[str, object, str, int]]:
    """Candidate ``alt`` fields (message name, decoded message, field, priority): the
    controller's barometric altitude ``CTUN.BarAlt``/``BAlt`` (1), ``BARO.Alt`` (2); the
    rangefinder (0) wins over both."""
    out = []
    if ctun is not None:
        for field in ("BarAlt", "BAlt"):
            if ctun.has(field):  # type: ignore[attr-defined]
                out.append(("CTUN", ctun, field, 1))
                break
    if baro is not None and baro.has("Alt"):  # type: ignore[attr-defined]
        out.append(("BARO", baro, "Alt", 2))
    return out
