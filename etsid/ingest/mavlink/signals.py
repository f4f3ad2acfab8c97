"""MAVLink messages → FlightTable signals: which fields, which units, which priority.

Each decoder takes the decoded payloads of one message (a numpy structured array), their
autopilot times (s), the read options and the list of repaired-sample counts, and returns
candidate signals already in SI units and FRD body / NED world frames (MAVLink's own
conventions, so no rotation). PWM goes through :mod:`etsid.ingest.rc` (the RC range of the
read options, clipped and counted).
Priorities (lower wins; see docs/ingest_mavlink.md):

======== ==================================================================================
column   candidates (priority)
======== ==================================================================================
p q r    ATTITUDE rollspeed… (0), HIGHRES_IMU gyro (2), SCALED_IMU/2/3 gyro mrad/s (3/4/5),
         RAW_IMU gyro (9, assumed mrad/s as ArduPilot sends it)
roll…    ATTITUDE (0)
ax ay az HIGHRES_IMU (0), SCALED_IMU/2/3 mG (1/2/3), RAW_IMU (9, assumed mG)
u_*      RC_CHANNELS (0), RC_CHANNELS_RAW (1) via ``rc_map``; ATTITUDE_TARGET.thrust (5)
sp_*     ATTITUDE_TARGET body rates (0); samples whose ``type_mask`` ignores them are NaN
sp_roll… ATTITUDE_TARGET q (w, x, y, z; NED from FRD) → ZYX Euler angles (0); NaN where
         ``type_mask`` bit 128 ignores the attitude or the quaternion is not a rotation
m1…m8    SERVO_OUTPUT_RAW servo1..8 (0), RC range (1000–2000 µs) → 0…1, port 0 only
alt      DISTANCE_SENSOR cm, orientation 25 (downward) only (0), LOCAL_POSITION_NED −z (5),
         GLOBAL_POSITION_INT relative_alt mm (8)
vx vy vz LOCAL_POSITION_NED (0), GLOBAL_POSITION_INT cm/s (2)
vbat     SYS_STATUS voltage_battery mV (0), BATTERY_STATUS sum of cell voltages mV (1)
landed   EXTENDED_SYS_STATE.landed_state (0: ON_GROUND → 1, IN_AIR/TAKEOFF/LANDING → 0,
         UNDEFINED → no value); HEARTBEAT.base_mode armed flag (1: disarmed → 1, armed → 0,
         an *armed state*, see :mod:`etsid.ident.flight`)
======== ==================================================================================
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from etsid.frames import quat_to_euler
from etsid.ingest.base import Issue, ReadOptions, Signal
from etsid.ingest.rc import motor_from_pwm, stick_from_pwm

G = 9.80665
Decoder = Callable[[np.ndarray, np.ndarray, ReadOptions, list[Issue]], list[Signal]]

CLOCK_FIELDS: dict[str, tuple[str, str]] = {
    "ATTITUDE": ("time_boot_ms", "ms"),
    "HIGHRES_IMU": ("time_usec", "us"),
    "SCALED_IMU": ("time_boot_ms", "ms"),
    "SCALED_IMU2": ("time_boot_ms", "ms"),
    "SCALED_IMU3": ("time_boot_ms", "ms"),
    "RAW_IMU": ("time_usec", "us"),
    "RC_CHANNELS": ("time_boot_ms", "ms"),
    "RC_CHANNELS_RAW": ("time_boot_ms", "ms"),
    "SERVO_OUTPUT_RAW": ("time_usec", "us32"),
    "ATTITUDE_TARGET": ("time_boot_ms", "ms"),
    "DISTANCE_SENSOR": ("time_boot_ms", "ms"),
    "LOCAL_POSITION_NED": ("time_boot_ms", "ms"),
    "GLOBAL_POSITION_INT": ("time_boot_ms", "ms"),
    "SYS_STATUS": ("", ""),
    "HEARTBEAT": ("", ""),
    "EXTENDED_SYS_STATE": ("", ""),
    "BATTERY_STATUS": ("", ""),
}
"""Message → (clock field, kind): ms = uint32 ms boot, us = uint64 µs, us32 = uint32 µs."""


def _f(a: np.ndarray, name: str, scale: float = 1.0) -> np.ndarray:
    values = a[name].astype(np.float64)
    return values * scale if scale != 1.0 else values  # (x · 1 is x: one pass less)


def _where(keep: np.ndarray, a: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The records ``a`` and times ``t`` where ``keep``; the arrays themselves when that is
    every record (numpy copies packed records field by field: 10 ms for 150,000)."""
    return (a, t) if keep.all() else (a[keep], t[keep])


def _sig(column: str, t: np.ndarray, values: np.ndarray, source: str, prio: int) -> Signal:
    return Signal(column, t, values, source, prio)


def _xyz(msg: str, a: np.ndarray, t: np.ndarray, fields: tuple[str, str, str],
         columns: tuple[str, str, str], scale: float, prio: int) -> list[Signal]:
    return [_sig(c, t, _f(a, f, scale), f"{msg}.{f}", prio)
            for c, f in zip(columns, fields, strict=True)]


def attitude(a: np.ndarray, t: np.ndarray, o: ReadOptions,
        repaired: list[Issue]) -> list[Signal]:
    return (_xyz("ATTITUDE", a, t, ("roll", "pitch", "yaw"), ("roll", "pitch", "yaw"), 1, 0)
            + _xyz("ATTITUDE", a, t, ("rollspeed", "pitchspeed", "yawspeed"),
                   ("p", "q", "r"), 1, 0))


def _imu(msg: str, gyro_scale: float, acc_scale: float, gyro_prio: int,
         acc_prio: int) -> Decoder:
    def decode(a: np.ndarray, t: np.ndarray, o: ReadOptions,
        repaired: list[Issue]) -> list[Signal]:
        return (_xyz(msg, a, t, ("xgyro", "ygyro", "zgyro"), ("p", "q", "r"), gyro_scale,
                     gyro_prio)
                + _xyz(msg, a, t, ("xacc", "yacc", "zacc"), ("ax", "ay", "az"), acc_scale,
                       acc_prio))
    return decode


def _rc(msg: str, nchan: int, prio: int) -> Decoder:
    def decode(a: np.ndarray, t: np.ndarray, o: ReadOptions,
               repaired: list[Issue]) -> list[Signal]:
        out = []
        for column, ch in o.rc_map.items():
            if not 1 <= ch <= nchan:
                continue
            name = f"chan{ch}_raw"
            pwm = a[name].copy()
            if "chancount" in (a.dtype.names or ()):
                count = a["chancount"]
                pwm[(count > 0) & (count < ch)] = 0  # beyond the channels sent: no value
            v = stick_from_pwm(pwm, column, f"{msg}.{name}", o, repaired)
            if np.isfinite(v).any():
                out.append(_sig(column, t, v, f"{msg}.{name}", prio))
        return out
    return decode


def servo_output_raw(a: np.ndarray, t: np.ndarray, o: ReadOptions,
                     repaired: list[Issue]) -> list[Signal]:
    a, t = _where(a["port"] == 0, a, t)
    out = []
    for i in range(1, 9):
        name = f"servo{i}_raw"
        raw = a[name]
        if not (raw != 0).any():
            continue
        v = motor_from_pwm(raw, f"SERVO_OUTPUT_RAW.{name}", o, repaired)
        out.append(_sig(f"m{i}", t, v, f"SERVO_OUTPUT_RAW.{name}", 0))
    return out


def attitude_target(a: np.ndarray, t: np.ndarray, o: ReadOptions,
        repaired: list[Issue]) -> list[Signal]:
    mask = a["type_mask"]
    out = []
    for bit, field, column in ((1, "body_roll_rate", "sp_p"), (2, "body_pitch_rate", "sp_q"),
                               (4, "body_yaw_rate", "sp_r"), (64, "thrust", "u_thrust")):
        v = _f(a, field)
        v[(mask & bit) != 0] = np.nan
        if np.isfinite(v).any():
            out.append(_sig(column, t, v, f"ATTITUDE_TARGET.{field}", 5 if bit == 64 else 0))
    q = a["q"].astype(np.float64)
    norm = np.einsum("ij,ij->i", q, q)
    keep = ((mask & 128) == 0) & (np.abs(norm - 1.0) < 0.1)
    if keep.any():
        euler = quat_to_euler(*(q / np.sqrt(np.where(norm > 0, norm, 1.0))[:, None]).T)
        for column, values in zip(("sp_roll", "sp_pitch", "sp_yaw"), euler, strict=True):
            out.append(_sig(column, t, np.where(keep, values, np.nan), "ATTITUDE_TARGET.q", 0))
    return out


def distance_sensor(a: np.ndarray, t: np.ndarray, o: ReadOptions,
        repaired: list[Issue]) -> list[Signal]:
    down = a["orientation"] == 25
    if not down.any():
        return []
    a, t = _where(down, a, t)
    v = _f(a, "current_distance", 0.01)
    bad = (a["current_distance"] < a["min_distance"]) | (a["current_distance"] > a["max_distance"])
    v[bad & (a["max_distance"] > 0)] = np.nan
    return [_sig("alt", t, v, "DISTANCE_SENSOR.current_distance", 0)]


def local_position_ned(a: np.ndarray, t: np.ndarray, o: ReadOptions,
        repaired: list[Issue]) -> list[Signal]:
    vel = _xyz("LOCAL_POSITION_NED", a, t, ("vx", "vy", "vz"), ("vx", "vy", "vz"), 1, 0)
    return [*vel, _sig("alt", t, -_f(a, "z"), "LOCAL_POSITION_NED.z", 5)]


def global_position_int(a: np.ndarray, t: np.ndarray, o: ReadOptions,
        repaired: list[Issue]) -> list[Signal]:
    vel = _xyz("GLOBAL_POSITION_INT", a, t, ("vx", "vy", "vz"), ("vx", "vy", "vz"), 0.01, 2)
    alt = _f(a, "relative_alt", 1e-3)
    return [*vel, _sig("alt", t, alt, "GLOBAL_POSITION_INT.relative_alt", 8)]


def sys_status(a: np.ndarray, t: np.ndarray, o: ReadOptions,
        repaired: list[Issue]) -> list[Signal]:
    raw = a["voltage_battery"]
    v = raw.astype(np.float64) * 1e-3
    v[(raw == 65535) | (raw == 0)] = np.nan
    if not np.isfinite(v).any():
        return []
    return [_sig("vbat", t, v, "SYS_STATUS.voltage_battery", 0)]


def battery_status(a: np.ndarray, t: np.ndarray, o: ReadOptions,
        repaired: list[Issue]) -> list[Signal]:
    first = a["id"] == a["id"].min() if a.size else a["id"] == 0
    a, t = _where(first, a, t)
    cells = a["voltages"].astype(np.float64)
    cells[a["voltages"] == 65535] = np.nan
    total = np.nansum(cells, axis=1) * 1e-3
    total[~np.isfinite(cells).any(axis=1)] = np.nan
    if not np.isfinite(total).any():
        return []
    return [_sig("vbat", t, total, "BATTERY_STATUS.voltages", 1)]


MAV_MODE_FLAG_SAFETY_ARMED = 128
"""HEARTBEAT.base_mode bit: motors armed."""

MAV_LANDED_STATE_ON_GROUND = 1
"""EXTENDED_SYS_STATE.landed_state: 0 UNDEFINED, 1 ON_GROUND, 2 IN_AIR, 3 TAKEOFF, 4 LANDING."""


def heartbeat(a: np.ndarray, t: np.ndarray, o: ReadOptions,
              repaired: list[Issue]) -> list[Signal]:
    """Armed state as ``landed``: 1 disarmed (on the ground), 0 armed."""
    armed = (a["base_mode"] & MAV_MODE_FLAG_SAFETY_ARMED) != 0
    return [_sig("landed", t, np.where(armed, 0.0, 1.0), "HEARTBEAT.base_mode", 1)]


def extended_sys_state(a: np.ndarray, t: np.ndarray, o: ReadOptions,
                       repaired: list[Issue]) -> list[Signal]:
    """The autopilot's land detector: 1 on the ground, 0 in the air, taking off or landing."""
    state = a["landed_state"]
    v = np.where(state == MAV_LANDED_STATE_ON_GROUND, 1.0, 0.0)
    v[state == 0] = np.nan
    return [_sig("landed", t, v, "EXTENDED_SYS_STATE.landed_state", 0)]


DECODERS: dict[str, Decoder] = {
    "ATTITUDE": attitude,
    "HIGHRES_IMU": _imu("HIGHRES_IMU", 1.0, 1.0, 2, 0),
    "SCALED_IMU": _imu("SCALED_IMU", 1e-3, G * 1e-3, 3, 1),
    "SCALED_IMU2": _imu("SCALED_IMU2", 1e-3, G * 1e-3, 4, 2),
    "SCALED_IMU3": _imu("SCALED_IMU3", 1e-3, G * 1e-3, 5, 3),
    "RAW_IMU": _imu("RAW_IMU", 1e-3, G * 1e-3, 9, 9),
    "RC_CHANNELS": _rc("RC_CHANNELS", 18, 0),
    "RC_CHANNELS_RAW": _rc("RC_CHANNELS_RAW", 8, 1),
    "SERVO_OUTPUT_RAW": servo_output_raw,
    "ATTITUDE_TARGET": attitude_target,
    "DISTANCE_SENSOR": distance_sensor,
    "LOCAL_POSITION_NED": local_position_ned,
    "GLOBAL_POSITION_INT": global_position_int,
    "SYS_STATUS": sys_status,
    "BATTERY_STATUS": battery_status,
    "HEARTBEAT": heartbeat,
    "EXTENDED_SYS_STATE": extended_sys_state,
}
"""Message name → decoder (every message the tlog reader maps to columns)."""
