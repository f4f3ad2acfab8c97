"""Vectorised twins of the per-message row functions of :mod:`etsid.ingest.ros.messages`.

Each function takes a :class:`etsid.ingest.ros.fast.decode.Cols` (the columns of a decoded batch,
read like a message) and returns the float64 rows (messages × width) that the
per-message row function would give message by message, bit for bit: the same fields,
the same order, the same float64 conversions (float32 and integers widen exactly, NaN
pads short arrays).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

NS = 1_000_000_000
_MAX_US = (1 << 62) // 1000


def _stack(*cols: Any) -> np.ndarray:
    # damaged bytes (kept records of a damaged chunk) may hold values that do not convert
    # cleanly: they become inf/NaN, which the plausibility limits drop, not a numpy warning
    with np.errstate(invalid="ignore", over="ignore"):
        return np.column_stack([np.asarray(c, dtype=np.float64) for c in cols])


def _pad(values: np.ndarray, n: int, rows: int) -> np.ndarray:
    """First ``n`` elements of each row of ``values`` (2-D), NaN-padded to ``n``."""
    out = np.full((rows, n), np.nan)
    if values is not None and values.ndim == 2:
        k = min(n, values.shape[1])
        out[:, :k] = values[:, :k]
    return out


def _rows(m: Any) -> int:
    return len(m)


def _imu(m: Any) -> np.ndarray:
    w, a, o = m.angular_velocity, m.linear_acceleration, m.orientation
    return _stack(w.x, w.y, w.z, a.x, a.y, a.z, o.w, o.x, o.y, o.z,
                  m.angular_velocity_covariance[:, 0], m.linear_acceleration_covariance[:, 0],
                  m.orientation_covariance[:, 0])


def _pose(p: Any) -> list[Any]:
    return [p.position.x, p.position.y, p.position.z,
            p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z]


def _odom(m: Any) -> np.ndarray:
    lin, ang = m.twist.twist.linear, m.twist.twist.angular
    return _stack(*_pose(m.pose.pose), lin.x, lin.y, lin.z, ang.x, ang.y, ang.z)


def _channels(m: Any) -> np.ndarray:
    try:
        values = m.channels
    except AttributeError:
        if not hasattr(m, "header"):
            raise
        values = None  # an empty sequence: no field in the layout
    return _pad(values, 18, _rows(m))


def _manual(m: Any) -> np.ndarray:
    if hasattr(m, "roll"):
        thr = np.asarray(m.throttle, dtype=np.float64)
        return _stack(m.roll, m.pitch, m.yaw, (thr + 1.0) / 2.0)
    return _stack(m.y, m.x, m.r, m.z)


def _px4_battery(m: Any) -> np.ndarray:
    v = m.voltage_v if hasattr(m, "voltage_v") else m.voltage_filtered_v
    return _stack(v)


def _motors(m: Any) -> np.ndarray:
    return _pad(m.control, 8, _rows(m))


FAST_ROWS: dict[str, Callable[[Any], np.ndarray]] = {
    "sensor_msgs/Imu": _imu,
    "nav_msgs/Odometry": _odom,
    "geometry_msgs/PoseStamped": lambda m: _stack(*_pose(m.pose)),
    "geometry_msgs/TwistStamped": lambda m: _stack(m.twist.linear.x, m.twist.linear.y,
                                                   m.twist.linear.z),
    "sensor_msgs/Range": lambda m: _stack(m.range, m.min_range, m.max_range),
    "sensor_msgs/BatteryState": lambda m: _stack(m.voltage),
    "mavros_msgs/RCIn": _channels,
    "mavros_msgs/RCOut": _channels,
    "mavros_msgs/AttitudeTarget": lambda m: _stack(m.type_mask, m.body_rate.x, m.body_rate.y,
                                                   m.body_rate.z, m.thrust, m.orientation.w,
                                                   m.orientation.x, m.orientation.y,
                                                   m.orientation.z),
    "px4_msgs/VehicleAngularVelocity": lambda m: _stack(*m.xyz.T),
    "px4_msgs/VehicleAttitude": lambda m: _stack(*m.q.T),
    "px4_msgs/ManualControlSetpoint": _manual,
    "px4_msgs/VehicleRatesSetpoint": lambda m: _stack(m.roll, m.pitch, m.yaw,
                                                      m.thrust_body[:, 2]),
    "px4_msgs/ActuatorMotors": _motors,
    "px4_msgs/VehicleLocalPosition": lambda m: _stack(m.vx, m.vy, m.vz, m.z, m.dist_bottom,
                                                      m.dist_bottom_valid != 0),
    "px4_msgs/DistanceSensor": lambda m: _stack(m.current_distance, m.orientation),
    "px4_msgs/BatteryStatus": _px4_battery,
    "px4_msgs/SensorCombined": lambda m: _stack(*m.gyro_rad.T, *m.accelerometer_m_s2.T),
}
"""Canonical message type → vectorised row function."""


def fast_clock(spec: Any, m: Any) -> np.ndarray:
    """The message clock of every message of the batch (int64 ns), as ``spec.clock`` gives.

    Raises
    ------
    ValueError
        A clock this module does not vectorise, or px4 timestamps too large for int64 ns.
    """
    name = getattr(spec.clock, "__name__", "")
    if name == "_stamp_ns":
        stamp = m.header.stamp
        sec = stamp.sec if hasattr(stamp, "sec") else stamp.secs
        nsec = stamp.nanosec if hasattr(stamp, "nanosec") else stamp.nsecs
        return np.asarray(sec, dtype=np.int64) * NS + np.asarray(nsec, dtype=np.int64)
    if name == "_px4_ns":
        ts = np.asarray(m.timestamp)
        if ts.dtype.kind not in "iu" or (len(ts) and ts.max() > _MAX_US):
            raise ValueError("timestamp out of range")
        return ts.astype(np.int64) * 1000
    raise ValueError(f"clock {name!r} not vectorised")
