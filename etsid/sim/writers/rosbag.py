"""Write a FlightTable as a ROS 1 bag or a ROS 2 bag with MAVROS topics (FLU body, ENU world).

Topics, types and native rates (as MAVROS publishes them; each stream decimated from the
table to its own rate):

==========================================  ==============================  ======
topic                                       type                            rate
==========================================  ==============================  ======
/mavros/imu/data                            sensor_msgs/Imu                 100 Hz
/mavros/rc/in                               mavros_msgs/RCIn                25 Hz
/mavros/rc/out                              mavros_msgs/RCOut               25 Hz
/mavros/setpoint_raw/target_attitude        mavros_msgs/AttitudeTarget      50 Hz
/mavros/distance_sensor/rangefinder_pub     sensor_msgs/Range               20 Hz
/mavros/local_position/velocity_local       geometry_msgs/TwistStamped      30 Hz
/mavros/battery                             sensor_msgs/BatteryState        2 Hz
==========================================  ==============================  ======

A topic is written only when the table has its columns; each is sampled from the table at
its own clock (linear, angles unwrapped, commands held). ``header.stamp`` is
``attrs["start_time"]`` (default 1.7e9 s) + ``t``; the record time is 1 ms later.
RC channels follow ArduPilot's AETR order; sticks and motors become PWM through
:mod:`etsid.pwm` (default range 1000/1500/2000 µs; channels 5–8 at min, min, centre, centre).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.frames import ned_frd_euler_to_enu_flu_quat
from etsid.pwm import DEFAULT_RC_RANGE_US, UNUSED, RcRange, motor_to_pwm, stick_to_pwm

NS = 1_000_000_000
RECORD_DELAY_NS = 1_000_000
DEFAULT_START = 1.7e9
RATES = {"imu": 100.0, "rc_in": 25.0, "rc_out": 25.0, "target": 50.0, "range": 20.0,
         "velocity": 30.0, "battery": 2.0}
RANGE_LIMITS = (0.05, 40.0)
"""min_range, max_range of the simulated rangefinder, m."""

Message = tuple[int, int, str, str, dict[str, Any]]
"""(record time ns, order, topic, type, fields as nested dicts in ROS 2 naming)."""


def _ticks(t: np.ndarray, rate: float) -> np.ndarray:
    """Times of a ``rate`` Hz clock over the table's span, s."""
    return t[0] + np.arange(int((t[-1] - t[0]) * rate + 1e-9) + 1) / rate


def resample_at(table: pd.DataFrame, ticks: np.ndarray) -> pd.DataFrame:
    """The table's columns at ``ticks`` (linear; angles unwrapped; commands held)."""
    from etsid.table import COLUMNS

    t = np.asarray(table.index, dtype=float)
    out = {}
    for name in table.columns:
        values = table[name].to_numpy(dtype=float)
        kind = COLUMNS[name].interp if name in COLUMNS else "linear"
        if kind == "hold":
            out[name] = values[np.clip(np.searchsorted(t, ticks, side="right") - 1, 0, None)]
        elif kind == "angle":
            out[name] = np.angle(np.exp(1j * np.interp(ticks, t, np.unwrap(values))))
        else:
            out[name] = np.interp(ticks, t, values)
    return pd.DataFrame(out, index=pd.Index(ticks, name="t"))


def _header(stamp_ns: int, frame: str = "base_link") -> dict[str, Any]:
    return {"stamp": {"sec": stamp_ns // NS, "nanosec": stamp_ns % NS}, "frame_id": frame}


def _vec(x: float, y: float, z: float) -> dict[str, float]:
    return {"x": float(x), "y": float(y), "z": float(z)}


def _col(table: pd.DataFrame, name: str, default: float = math.nan) -> np.ndarray:
    if name in table.columns:
        return table[name].to_numpy(dtype=float)
    return np.full(len(table), default)


def _pwm(us: float) -> int:
    """A uint16 channel value: PWM rounded, 0 for no value."""
    return int(np.clip(np.rint(us), 0, UNUSED)) if np.isfinite(us) else 0


def _imu(table: pd.DataFrame) -> Callable[[int, int], dict[str, Any]] | None:
    if not {"p", "q", "r"} <= set(table.columns):
        return None
    p, q, r = _col(table, "p"), _col(table, "q"), _col(table, "r")
    ax, ay, az = _col(table, "ax"), _col(table, "ay"), _col(table, "az")
    has_acc = {"ax", "ay", "az"} <= set(table.columns)
    has_att = {"roll", "pitch", "yaw"} <= set(table.columns)
    if has_att:
        qw, qx, qy, qz = ned_frd_euler_to_enu_flu_quat(_col(table, "roll"), _col(table, "pitch"),
                                                       _col(table, "yaw"))
    else:
        qw, qx, qy, qz = (np.zeros(len(table)) for _ in range(4))

    def make(i: int, stamp: int) -> dict[str, Any]:
        return {"header": _header(stamp),
                "orientation": {"x": float(qx[i]), "y": float(qy[i]), "z": float(qz[i]),
                                "w": float(qw[i])},
                "orientation_covariance": [0.0 if has_att else -1.0] + [0.0] * 8,
                "angular_velocity": _vec(p[i], -q[i], -r[i]),
                "angular_velocity_covariance": [0.0] * 9,
                "linear_acceleration": _vec(ax[i], -ay[i], -az[i]) if has_acc else _vec(0, 0, 0),
                "linear_acceleration_covariance": [0.0 if has_acc else -1.0] + [0.0] * 8}
    return make


def _rc_in(table: pd.DataFrame, rc_range_us: RcRange
           ) -> Callable[[int, int], dict[str, Any]] | None:
    sticks = ("u_roll", "u_pitch", "u_thrust", "u_yaw")  # AETR: channels 1..4
    if not set(sticks) & set(table.columns):
        return None
    pwm = [stick_to_pwm(_col(table, s, 0.0), s, rc_range_us) for s in sticks]
    lo, centre, _ = rc_range_us
    rest = [_pwm(lo), _pwm(lo), _pwm(centre), _pwm(centre)]

    def make(i: int, stamp: int) -> dict[str, Any]:
        chans = [_pwm(c[i]) for c in pwm] + rest
        return {"header": _header(stamp, ""), "rssi": 255, "channels": chans}
    return make


def _rc_out(table: pd.DataFrame, rc_range_us: RcRange
            ) -> Callable[[int, int], dict[str, Any]] | None:
    motors = [c for c in (f"m{i}" for i in range(1, 9)) if c in table.columns]
    if not motors:
        return None
    n = int(motors[-1][1:])
    cols = [motor_to_pwm(_col(table, f"m{i}"), rc_range_us) for i in range(1, n + 1)]

    def make(i: int, stamp: int) -> dict[str, Any]:
        return {"header": _header(stamp, ""), "channels": [_pwm(c[i]) for c in cols]}
    return make


def _target(table: pd.DataFrame) -> Callable[[int, int], dict[str, Any]] | None:
    if not {"sp_p", "sp_q", "sp_r"} <= set(table.columns):
        return None
    sp, sq, sr = _col(table, "sp_p"), _col(table, "sp_q"), _col(table, "sp_r")
    thrust = _col(table, "u_thrust")
    mask = 128 | (0 if "u_thrust" in table.columns else 64)

    def make(i: int, stamp: int) -> dict[str, Any]:
        return {"header": _header(stamp, ""), "type_mask": mask,
                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
                "body_rate": _vec(sp[i], -sq[i], -sr[i]),
                "thrust": float(thrust[i]) if np.isfinite(thrust[i]) else 0.0}
    return make


def _range(table: pd.DataFrame) -> Callable[[int, int], dict[str, Any]] | None:
    if "alt" not in table.columns:
        return None
    alt = _col(table, "alt")

    def make(i: int, stamp: int) -> dict[str, Any]:
        return {"header": _header(stamp, "rangefinder"), "radiation_type": 1,
                "field_of_view": 0.1, "min_range": RANGE_LIMITS[0],
                "max_range": RANGE_LIMITS[1], "range": float(alt[i])}
    return make


def _velocity(table: pd.DataFrame) -> Callable[[int, int], dict[str, Any]] | None:
    if not {"vx", "vy", "vz"} <= set(table.columns):
        return None
    vx, vy, vz = _col(table, "vx"), _col(table, "vy"), _col(table, "vz")

    def make(i: int, stamp: int) -> dict[str, Any]:
        return {"header": _header(stamp, "map"),
                "twist": {"linear": _vec(vy[i], vx[i], -vz[i]), "angular": _vec(0, 0, 0)}}
    return make


def _battery(table: pd.DataFrame) -> Callable[[int, int], dict[str, Any]] | None:
    if "vbat" not in table.columns:
        return None
    vbat = _col(table, "vbat")

    def make(i: int, stamp: int) -> dict[str, Any]:
        return {"header": _header(stamp, ""), "voltage": float(vbat[i]),
                "temperature": math.nan, "current": math.nan, "charge": math.nan,
                "capacity": math.nan, "design_capacity": math.nan, "percentage": math.nan,
                "power_supply_status": 2, "power_supply_health": 1,
                "power_supply_technology": 3, "present": True,
                "cell_voltage": [], "cell_temperature": [], "location": "", "serial_number": ""}
    return make


TOPICS: list[tuple[str, str, str, Callable[..., Any]]] = [
    ("/mavros/imu/data", "sensor_msgs/msg/Imu", "imu", _imu),
    ("/mavros/rc/in", "mavros_msgs/msg/RCIn", "rc_in", _rc_in),
    ("/mavros/rc/out", "mavros_msgs/msg/RCOut", "rc_out", _rc_out),
    ("/mavros/setpoint_raw/target_attitude", "mavros_msgs/msg/AttitudeTarget", "target",
     _target),
    ("/mavros/distance_sensor/rangefinder_pub", "sensor_msgs/msg/Range", "range", _range),
    ("/mavros/local_position/velocity_local", "geometry_msgs/msg/TwistStamped", "velocity",
     _velocity),
    ("/mavros/battery", "sensor_msgs/msg/BatteryState", "battery", _battery),
]
"""(topic, ROS 2 type name, rate key, message builder factory).

A factory takes the table resampled to the topic's rate (the RC ones also the RC range)
and returns a builder ``(sample index, stamp ns) -> fields``, or None when the table lacks
the topic's columns."""
PWM_FACTORIES = (_rc_in, _rc_out)


def mavros_messages(table: pd.DataFrame, rc_range_us: RcRange = DEFAULT_RC_RANGE_US,
                    rates: dict[str, float] | None = None
                    ) -> tuple[list[tuple[str, str]], Iterator[Message]]:
    """Topics (name, type) and the time-ordered stream of MAVROS messages for ``table``.

    ``rc_range_us`` (PWM min, centre, max, µs) converts sticks and motors to RC and servo
    channels (:mod:`etsid.pwm`). ``rates`` overrides the stream rates of :data:`RATES`
    (Hz, keyed ``imu``, ``rc_in`` …; 0 drops a topic).
    """
    rates = {**RATES, **(rates or {})}
    unknown = sorted(set(rates) - set(RATES))
    if unknown:
        raise ValueError(f"unknown MAVROS stream(s) {', '.join(unknown)}; "
                         f"known: {', '.join(RATES)}")
    t = np.asarray(table.index, dtype=float)
    start_ns = round(float(table.attrs.get("start_time") or DEFAULT_START) * NS)
    topics, streams = [], []
    for order, (topic, msgtype, key, factory) in enumerate(TOPICS):
        if rates[key] <= 0:
            continue
        ticks = _ticks(t, rates[key])
        frame = resample_at(table, ticks)
        make = factory(frame, rc_range_us) if factory in PWM_FACTORIES else factory(frame)
        if make is None:
            continue
        stamps = start_ns + np.round((ticks - t[0]) * NS).astype(np.int64)
        topics.append((topic, msgtype))
        streams.append(_stream(make, stamps, order, topic, msgtype))
    return topics, heapq.merge(*streams, key=lambda m: (m[0], m[1]))


def _stream(make: Callable[[int, int], dict[str, Any]], stamps: np.ndarray, order: int,
            topic: str, msgtype: str) -> Iterator[Message]:
    for i, stamp in enumerate(stamps.tolist()):
        yield stamp + RECORD_DELAY_NS, order, topic, msgtype, make(i, stamp)


def instantiate(store: Any, typename: str, values: dict[str, Any]) -> Any:
    """A rosbags message object of ``typename`` from nested dicts (missing fields default)."""
    from rosbags.typesys.base import Nodetype

    _, fields = store.fielddefs[typename]
    kwargs: dict[str, Any] = {}
    for name, (kind, detail) in fields:
        value = values.get(name)
        if kind == Nodetype.NAME:
            kwargs[name] = instantiate(store, detail, value or {})
        elif kind == Nodetype.BASE:
            base = detail[0]
            if value is None:
                value = "" if base == "string" else (False if base == "bool" else 0)
            kwargs[name] = value
        else:
            inner, size = detail if kind == Nodetype.ARRAY else (detail[0], 0)
            if inner[0] == Nodetype.BASE and inner[1][0] != "string":
                dtype = np.dtype("uint8" if inner[1][0] in ("byte", "char") else
                                 {"bool": "bool"}.get(inner[1][0], inner[1][0]))
                arr = np.asarray(value if value is not None else [], dtype=dtype)
                if kind == Nodetype.ARRAY and arr.size != size:
                    arr = np.zeros(size, dtype=dtype)
                kwargs[name] = arr
            else:
                kwargs[name] = list(value or [])
    return store.types[typename](**kwargs)


def write_ros1_bag(table: pd.DataFrame, path: Path,
                   rc_range_us: RcRange = DEFAULT_RC_RANGE_US,
                   rates: dict[str, float] | None = None) -> Path:
    """Write ``table`` as a ROS 1 bag (lz4 chunks) with MAVROS topics; returns ``path``.

    ``rc_range_us``: PWM min, centre, max (µs) of the RC and servo channels; ``rates``:
    stream rate overrides, Hz (:func:`mavros_messages`).
    """
    from rosbags.rosbag1 import Writer

    from etsid.rosmsgs import typestore

    path = Path(path)
    path.unlink(missing_ok=True)
    store = typestore(ros1=True)
    topics, messages = mavros_messages(table, rc_range_us, rates)
    writer = Writer(path)
    writer.set_compression(Writer.CompressionFormat.LZ4)
    with writer:
        conns = {name: writer.add_connection(name, msgtype, typestore=store)
                 for name, msgtype in topics}
        for log_ns, _, topic, msgtype, fields in messages:
            msg = instantiate(store, msgtype, fields)
            writer.write(conns[topic], log_ns, store.serialize_ros1(msg, msgtype))
    return path


def write_ros2_bag(table: pd.DataFrame, path: Path, storage: str = "sqlite3",
                   rc_range_us: RcRange = DEFAULT_RC_RANGE_US,
                   rates: dict[str, float] | None = None) -> Path:
    """Write ``table`` as a ROS 2 bag directory (``sqlite3`` or ``mcap`` storage); returns it.

    ``rc_range_us``: PWM min, centre, max (µs) of the RC and servo channels; ``rates``:
    stream rate overrides, Hz (:func:`mavros_messages`).
    """
    import shutil

    from rosbags.rosbag2 import StoragePlugin, Writer

    from etsid.rosmsgs import typestore

    path = Path(path)
    if path.exists():
        shutil.rmtree(path)
    plugin = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}[storage]
    store = typestore(ros1=False)
    topics, messages = mavros_messages(table, rc_range_us, rates)
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conns = {name: writer.add_connection(name, msgtype, typestore=store)
                 for name, msgtype in topics}
        for log_ns, _, topic, msgtype, fields in messages:
            msg = instantiate(store, msgtype, fields)
            writer.write(conns[topic], log_ns, store.serialize_cdr(msg, msgtype))
    return path
