"""Which ROS message types (ROS 1, ROS 2, MAVLink-as-JSON) fill which FlightTable columns.

Shared by :mod:`etsid.ingest.ros.bag` and :mod:`etsid.ingest.ros.mcap` through
:class:`etsid.ingest.ros.converter.Converter`. Each converted type has a :class:`Spec`: a
row of numbers per message, and a finish function that turns a topic's rows into SI,
FRD body / NED world signals.

Frames: ROS messages follow REP-103 (FLU body, ENU world, as MAVROS publishes them):
rates and specific force have y and z negated, orientation becomes
R_ned_frd = A·R_enu_flu·B, world vectors map ENU→NED. px4_msgs and MAVLink are FRD/NED.

Time: see :mod:`etsid.ingest.ros.converter` (``Spec.clock`` and ``Spec.boot`` say which
clock a type carries).

Priorities (lower wins; ties go to the higher rate, see :mod:`etsid.ingest.mapping`):

====================  ==========================================================  ====
column                source                                                      prio
====================  ==========================================================  ====
p q r                 px4 VehicleAngularVelocity; MAVLink ATTITUDE                 1
p q r                 sensor_msgs/Imu (a ``…raw`` topic: 3); px4 SensorCombined   2/3
p q r                 nav_msgs/Odometry twist.angular                               5
roll pitch yaw        px4 VehicleAttitude; MAVLink ATTITUDE                         1
roll pitch yaw        sensor_msgs/Imu orientation (``…raw``: 3)                     2/3
roll pitch yaw        nav_msgs/Odometry 5; geometry_msgs/PoseStamped 6             5/6
ax ay az              sensor_msgs/Imu (``…raw``: 3); px4 SensorCombined            2/3
u_*                   px4 ManualControlSetpoint 1; mavros RCIn, MAVLink RC 2       1/2
u_thrust              px4 VehicleRatesSetpoint thrust 4; mavros AttitudeTarget 5   4/5
sp_p sp_q sp_r        px4 VehicleRatesSetpoint 1; mavros AttitudeTarget 2          1/2
m1..m8                px4 ActuatorMotors 1; mavros RCOut, MAVLink SERVO_OUTPUT 2   1/2
alt                   downward Range / px4 DistanceSensor 1; px4 dist_bottom 2     1/2
alt                   px4 −z 3; Odometry / PoseStamped position z (ENU up) 4       3/4
vx vy vz              px4 VehicleLocalPosition 1; TwistStamped velocity_local 2    1/2
vx vy vz              nav_msgs/Odometry twist.linear rotated to NED                 4
vbat                  sensor_msgs/BatteryState, px4 BatteryStatus                   2
====================  ==========================================================  ====

Covariance −1 in sensor_msgs/Imu marks a field the driver does not provide: it is skipped.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np

from etsid.frames import enu_flu_quat_to_ned_frd_euler, quat_to_euler, quat_to_matrix
from etsid.ingest.base import Issue, ReadOptions, Signal
from etsid.ingest.rc import motor_from_pwm, stick_from_pwm

NS = 1_000_000_000
NAN = math.nan
DOWNWARD_HINTS = ("rangefinder", "distance_sensor", "down", "altitude", "height", "agl")
SERVICE_NOTE = "service events: listed, not flight data"


def message_type(name: str) -> str:
    """Canonical type name: ``sensor_msgs/msg/Imu`` → ``sensor_msgs/Imu``."""
    return name.strip().replace("/msg/", "/")


def as_message(obj: Any) -> Any:
    """JSON-decoded dicts as attribute objects (lists kept), so converters read them alike."""
    if isinstance(obj, dict):
        return SimpleNamespace(**{k: as_message(v) for k, v in obj.items()})
    if isinstance(obj, list):
        return [as_message(v) for v in obj]
    return obj


# ---------------------------------------------------------------------------
# per-type row extraction and finishing


def _stamp_ns(msg: Any) -> int:
    st = msg.header.stamp
    sec = getattr(st, "sec", None)
    if sec is None:
        return int(st.secs) * NS + int(st.nsecs)
    return int(sec) * NS + int(st.nanosec)


def _px4_ns(msg: Any) -> int:
    return int(msg.timestamp) * 1000


def _boot_ms_ns(msg: Any) -> int:
    return int(msg.time_boot_ms) * 1_000_000


def _boot_us_ns(msg: Any) -> int:
    return int(msg.time_usec) * 1000


def _pad(values: Sequence[float], n: int) -> tuple[float, ...]:
    vals = tuple(float(v) for v in values[:n])
    return vals + (NAN,) * (n - len(vals))


@dataclass
class Batch:
    """Rows collected for one topic, handed to a finish function."""

    topic: str
    t: np.ndarray
    rows: np.ndarray
    options: ReadOptions
    dropped: list[Issue]
    repaired: list[Issue]

    def col(self, i: int) -> np.ndarray:
        return self.rows[:, i]

    def signal(self, column: str, values: np.ndarray, fld: str, priority: int,
               keep: np.ndarray | None = None, why: str = "") -> Signal:
        """A signal, keeping only rows ``keep`` (the others counted as dropped for ``why``)."""
        t = self.t
        if keep is not None and not keep.all():
            if why:
                self.dropped.append(Issue(why, int((~keep).sum()), f"{self.topic}.{fld}"))
            t, values = t[keep], values[keep]
        return Signal(column, t, np.asarray(values, dtype=float), f"{self.topic}.{fld}", priority)


Finish = Callable[[Batch], list[Signal]]


@dataclass(frozen=True)
class Spec:
    """How one message type becomes signals: a row of numbers per message, then a finish."""

    row: Callable[[Any], Sequence[float]]
    finish: Finish
    clock: Callable[[Any], int] | None = _stamp_ns
    boot: bool = False
    """The clock is the autopilot boot clock (px4 ``timestamp``, MAVLink ``time_boot_ms``)."""


def _is_raw(topic: str) -> bool:
    return topic.rstrip("/").endswith("raw")


def _imu_row(m: Any) -> tuple[float, ...]:
    w, a, o = m.angular_velocity, m.linear_acceleration, m.orientation
    return (w.x, w.y, w.z, a.x, a.y, a.z, o.w, o.x, o.y, o.z,
            m.angular_velocity_covariance[0], m.linear_acceleration_covariance[0],
            m.orientation_covariance[0])


def _imu_finish(b: Batch) -> list[Signal]:
    prio = 3 if _is_raw(b.topic) else 2
    out = []
    for base, names, cols, fld in ((0, ("p", "q", "r"), 10, "angular_velocity"),
                                  (3, ("ax", "ay", "az"), 11, "linear_acceleration")):
        keep = b.col(cols) != -1
        if keep.any():
            x, y, z = b.col(base), -b.col(base + 1), -b.col(base + 2)
            for name, values, axis in zip(names, (x, y, z), "xyz", strict=True):
                out.append(b.signal(name, values, f"{fld}.{axis}", prio, keep,
                                    "covariance -1: field not provided"))
    quat = b.rows[:, 6:10]
    keep = (b.col(12) != -1) & (np.einsum("ij,ij->i", quat, quat) > 0.25)
    if keep.any():
        euler = enu_flu_quat_to_ned_frd_euler(*quat.T)
        for name, values in zip(("roll", "pitch", "yaw"), euler, strict=True):
            out.append(b.signal(name, values, "orientation", prio, keep,
                                "orientation not provided (covariance -1 or zero quaternion)"))
    return out


def _vec3_row(attr: str) -> Callable[[Any], tuple[float, ...]]:
    def row(m: Any) -> tuple[float, ...]:
        v = getattr(m.twist, attr)
        return (v.x, v.y, v.z)
    return row


def _twist_local_finish(b: Batch) -> list[Signal]:
    x, y, z = b.col(0), b.col(1), b.col(2)
    return [b.signal("vx", y, "twist.linear.y", 2), b.signal("vy", x, "twist.linear.x", 2),
            b.signal("vz", -z, "twist.linear.z", 2)]


def _pose_row(pose: Any) -> tuple[float, ...]:
    p, o = pose.position, pose.orientation
    return (p.x, p.y, p.z, o.w, o.x, o.y, o.z)


def _pose_signals(b: Batch, prefix: str, prio_alt: int, prio_att: int) -> list[Signal]:
    out = [b.signal("alt", b.col(2), f"{prefix}.position.z", prio_alt)]
    quat = b.rows[:, 3:7]
    keep = np.einsum("ij,ij->i", quat, quat) > 0.25
    if keep.any():
        euler = enu_flu_quat_to_ned_frd_euler(*quat.T)
        for name, values in zip(("roll", "pitch", "yaw"), euler, strict=True):
            out.append(b.signal(name, values, f"{prefix}.orientation", prio_att, keep,
                                "zero orientation quaternion"))
    return out


def _odom_row(m: Any) -> tuple[float, ...]:
    lin, ang = m.twist.twist.linear, m.twist.twist.angular
    return (*_pose_row(m.pose.pose), lin.x, lin.y, lin.z, ang.x, ang.y, ang.z)


def _odom_finish(b: Batch) -> list[Signal]:
    out = _pose_signals(b, "pose.pose", 4, 5)
    out += [b.signal("p", b.col(10), "twist.twist.angular.x", 5),
            b.signal("q", -b.col(11), "twist.twist.angular.y", 5),
            b.signal("r", -b.col(12), "twist.twist.angular.z", 5)]
    quat = b.rows[:, 3:7]
    keep = np.einsum("ij,ij->i", quat, quat) > 0.25
    if keep.any():  # body FLU twist → ENU world with the message's own orientation → NED
        v_enu = np.einsum("nij,nj->ni", quat_to_matrix(*quat.T), b.rows[:, 7:10])
        for name, values, axis in (("vx", v_enu[:, 1], "y"), ("vy", v_enu[:, 0], "x"),
                                   ("vz", -v_enu[:, 2], "z")):
            out.append(b.signal(name, values, f"twist.twist.linear.{axis}", 4, keep,
                                "zero orientation quaternion"))
    return out


def _range_finish(b: Batch) -> list[Signal]:
    rng, lo, hi = b.col(0), b.col(1), b.col(2)
    keep = np.isfinite(rng) & (rng >= lo) & ((rng <= hi) | (hi <= 0))
    return [b.signal("alt", rng, "range", 1, keep, "range outside min_range..max_range")]


def _battery_finish(b: Batch) -> list[Signal]:
    v = b.col(0)
    return [b.signal("vbat", v, "voltage", 2, v > 0, "voltage 0 or unknown")]


def _sticks(b: Batch, pwm: np.ndarray, fields: Callable[[int], str], prio: int) -> list[Signal]:
    out = []
    for stick, channel in b.options.rc_map.items():
        if channel > pwm.shape[1]:
            continue
        fld = fields(channel)
        values = stick_from_pwm(pwm[:, channel - 1], stick, f"{b.topic}.{fld}", b.options,
                                b.repaired)
        keep = np.isfinite(values)
        if keep.any():
            out.append(b.signal(stick, values, fld, prio, keep, "RC channel missing or unused"))
    return out


def _motors(b: Batch, pwm: np.ndarray, fields: Callable[[int], str], prio: int) -> list[Signal]:
    out = []
    for i in range(min(8, pwm.shape[1])):
        fld = fields(i + 1)
        values = motor_from_pwm(pwm[:, i], f"{b.topic}.{fld}", b.options, b.repaired)
        keep = np.isfinite(values)
        if keep.any():
            out.append(b.signal(f"m{i + 1}", values, fld, prio, keep,
                                "output channel missing or unused"))
    return out


def _channels_row(m: Any) -> tuple[float, ...]:
    return _pad(m.channels, 18)


def _rcin_finish(b: Batch) -> list[Signal]:
    return _sticks(b, b.rows, lambda c: f"channels[{c - 1}]", 2)


def _rcout_finish(b: Batch) -> list[Signal]:
    return _motors(b, b.rows, lambda c: f"channels[{c - 1}]", 2)


def _attitude_target_row(m: Any) -> tuple[float, ...]:
    r = m.body_rate
    return (m.type_mask, r.x, r.y, r.z, m.thrust)


def _attitude_target_finish(b: Batch) -> list[Signal]:
    mask = b.col(0).astype(np.int64)
    out = []
    for name, i, bit, sign, axis in (("sp_p", 1, 1, 1, "x"), ("sp_q", 2, 2, -1, "y"),
                                     ("sp_r", 3, 4, -1, "z")):
        keep = (mask & bit) == 0
        if keep.any():
            out.append(b.signal(name, sign * b.col(i), f"body_rate.{axis}", 2, keep,
                                "type_mask ignores this rate"))
    keep = (mask & 64) == 0
    if keep.any():
        out.append(b.signal("u_thrust", b.col(4), "thrust", 5, keep, "type_mask ignores thrust"))
    return out


def _xyz_signals(b: Batch, names: Sequence[str], fld: str, start: int, prio: int,
                 sign: Sequence[float] = (1, 1, 1)) -> list[Signal]:
    return [b.signal(n, s * b.col(start + i), f"{fld}[{i}]", prio)
            for i, (n, s) in enumerate(zip(names, sign, strict=True))]


def _manual_row(m: Any) -> tuple[float, ...]:
    if hasattr(m, "roll"):
        return (m.roll, m.pitch, m.yaw, (m.throttle + 1.0) / 2.0)
    return (m.y, m.x, m.r, m.z)  # PX4 before v1.14: x pitch, y roll, z throttle 0..1, r yaw


def _manual_finish(b: Batch) -> list[Signal]:
    return [b.signal(n, b.col(i), f, 1) for i, (n, f) in enumerate(
        (("u_roll", "roll"), ("u_pitch", "pitch"), ("u_yaw", "yaw"), ("u_thrust", "throttle")))]


def _rates_sp_finish(b: Batch) -> list[Signal]:
    return [b.signal("sp_p", b.col(0), "roll", 1), b.signal("sp_q", b.col(1), "pitch", 1),
            b.signal("sp_r", b.col(2), "yaw", 1),
            b.signal("u_thrust", -b.col(3), "thrust_body[2]", 4)]


def _local_position_row(m: Any) -> tuple[float, ...]:
    return (m.vx, m.vy, m.vz, m.z, m.dist_bottom, float(m.dist_bottom_valid))


def _local_position_finish(b: Batch) -> list[Signal]:
    out = [b.signal("vx", b.col(0), "vx", 1), b.signal("vy", b.col(1), "vy", 1),
           b.signal("vz", b.col(2), "vz", 1), b.signal("alt", -b.col(3), "z", 3)]
    valid = b.col(5) > 0
    if valid.any():
        out.append(b.signal("alt", b.col(4), "dist_bottom", 2, valid, "dist_bottom not valid"))
    return out


def _distance_finish(b: Batch) -> list[Signal]:
    down = b.col(1) == 25
    if not down.any():
        return []
    return [b.signal("alt", b.col(0), "current_distance", 1, down, "not downward facing")]


def _px4_battery_row(m: Any) -> tuple[float, ...]:
    v = getattr(m, "voltage_v", None)
    return (float(m.voltage_filtered_v if v is None else v),)


def _sensor_combined_finish(b: Batch) -> list[Signal]:
    return (_xyz_signals(b, ("p", "q", "r"), "gyro_rad", 0, 3)
            + _xyz_signals(b, ("ax", "ay", "az"), "accelerometer_m_s2", 3, 2))


def _mav_attitude_finish(b: Batch) -> list[Signal]:
    names = ("roll", "pitch", "yaw", "p", "q", "r")
    fields = ("roll", "pitch", "yaw", "rollspeed", "pitchspeed", "yawspeed")
    return [b.signal(n, b.col(i), f, 1) for i, (n, f) in enumerate(zip(names, fields,
                                                                         strict=True))]


def _mav_row(prefix: str, n: int) -> Callable[[Any], tuple[float, ...]]:
    names = [f"{prefix}{i}_raw" for i in range(1, n + 1)]

    def row(m: Any) -> tuple[float, ...]:
        return tuple(float(getattr(m, k, NAN)) for k in names)
    return row


SPECS: dict[str, Spec] = {
    "sensor_msgs/Imu": Spec(_imu_row, _imu_finish),
    "nav_msgs/Odometry": Spec(_odom_row, _odom_finish),
    "geometry_msgs/PoseStamped": Spec(lambda m: _pose_row(m.pose),
                                      lambda b: _pose_signals(b, "pose", 4, 6)),
    "sensor_msgs/Range": Spec(lambda m: (m.range, m.min_range, m.max_range), _range_finish),
    "sensor_msgs/BatteryState": Spec(lambda m: (m.voltage,), _battery_finish),
    "mavros_msgs/RCIn": Spec(_channels_row, _rcin_finish),
    "mavros_msgs/RCOut": Spec(_channels_row, _rcout_finish),
    "mavros_msgs/AttitudeTarget": Spec(_attitude_target_row, _attitude_target_finish),
    "px4_msgs/VehicleAngularVelocity": Spec(
        lambda m: tuple(m.xyz), lambda b: _xyz_signals(b, ("p", "q", "r"), "xyz", 0, 1),
        _px4_ns, True),
    "px4_msgs/VehicleAttitude": Spec(
        lambda m: tuple(m.q),
        lambda b: [b.signal(n, v, "q", 1) for n, v in
                   zip(("roll", "pitch", "yaw"), quat_to_euler(*b.rows.T), strict=True)],
        _px4_ns, True),
    "px4_msgs/ManualControlSetpoint": Spec(_manual_row, _manual_finish, _px4_ns, True),
    "px4_msgs/VehicleRatesSetpoint": Spec(
        lambda m: (m.roll, m.pitch, m.yaw, m.thrust_body[2]), _rates_sp_finish, _px4_ns, True),
    "px4_msgs/ActuatorMotors": Spec(
        lambda m: _pad(m.control, 8),
        lambda b: [b.signal(f"m{i + 1}", b.col(i), f"control[{i}]", 1)
                   for i in range(8) if np.isfinite(b.col(i)).any()],
        _px4_ns, True),
    "px4_msgs/VehicleLocalPosition": Spec(_local_position_row, _local_position_finish,
                                          _px4_ns, True),
    "px4_msgs/DistanceSensor": Spec(lambda m: (m.current_distance, m.orientation),
                                    _distance_finish, _px4_ns, True),
    "px4_msgs/BatteryStatus": Spec(
        _px4_battery_row,
        lambda b: [b.signal("vbat", b.col(0), "voltage_v", 2, b.col(0) > 0, "voltage 0")],
        _px4_ns, True),
    "px4_msgs/SensorCombined": Spec(
        lambda m: (*m.gyro_rad, *m.accelerometer_m_s2), _sensor_combined_finish, _px4_ns, True),
    "mavlink.ATTITUDE": Spec(
        lambda m: (m.roll, m.pitch, m.yaw, m.rollspeed, m.pitchspeed, m.yawspeed),
        _mav_attitude_finish, _boot_ms_ns, True),
    "mavlink.RC_CHANNELS": Spec(
        _mav_row("chan", 18), lambda b: _sticks(b, b.rows, lambda c: f"chan{c}_raw", 2),
        _boot_ms_ns, True),
    "mavlink.RC_CHANNELS_RAW": Spec(
        _mav_row("chan", 8), lambda b: _sticks(b, b.rows, lambda c: f"chan{c}_raw", 2),
        _boot_ms_ns, True),
    "mavlink.SERVO_OUTPUT_RAW": Spec(
        _mav_row("servo", 8), lambda b: _motors(b, b.rows, lambda c: f"servo{c}_raw", 2),
        _boot_us_ns, True),
}
"""Canonical message type → conversion (topic-dependent choices in :func:`spec_for`)."""


def spec_for(msgtype: str, topic: str) -> tuple[Spec | None, str]:
    """Conversion for a topic of ``msgtype``, or None and the reason it is not converted."""
    kind = message_type(msgtype)
    low = topic.lower()
    if kind.endswith("_Event") or "/srv/" in msgtype or low.endswith("/_service_event"):
        return None, SERVICE_NOTE
    if kind == "geometry_msgs/TwistStamped":
        if "velocity_local" in low or low.rstrip("/").endswith("local_position/velocity"):
            return Spec(_vec3_row("linear"), _twist_local_finish), ""
        return None, "twist frame not known from the topic name (use --map)"
    if kind == "sensor_msgs/Range" and not any(h in low for h in DOWNWARD_HINTS):
        return None, "range sensor not known to face down (use --map alt=TOPIC)"
    spec = SPECS.get(kind)
    if spec is None:
        return None, "message type not converted (use --map COLUMN=TOPIC.FIELD)"
    return spec, ""
