"""PX4 ULog (``.ulg``) via pyulog, parsing only the topics below.

pyulog reads the whole file into memory (it has no streaming API); only the listed topics
are decoded (``message_name_filter_list``). PX4 topics are already FRD body / NED world,
SI units; times are the ``timestamp`` field (µs since boot), or ``timestamp_sample``
(when the sensor sampled) for vehicle_angular_velocity, vehicle_attitude and
vehicle_local_position. Multi-instance topics use instance 0.

============ ============================================================================
column       candidates (priority, lower wins)
============ ============================================================================
p q r        vehicle_angular_velocity xyz (0), sensor_gyro x/y/z (1; the high-rate
             logging profile, raw FRD rad/s), sensor_combined gyro_rad (2)
roll…        vehicle_attitude q (0)
sp_roll…     vehicle_attitude_setpoint q_d (0), roll_body/pitch_body/yaw_body (1)
ax ay az     sensor_combined accelerometer_m_s2 (0), sensor_accel x/y/z (1)
landed       vehicle_land_detected landed (0)
ground_con…  vehicle_land_detected ground_contact or maybe_landed (0): the detector's
             stages between touch-down and ``landed`` (and before lift-off)
u_*          manual_control_setpoint (0; old fields x pitch, y roll, z throttle 0…1, r yaw;
             new fields roll, pitch, yaw, throttle −1…1 → 0…1), input_rc values via
             ``rc_map`` (1), controller torque/thrust commands: actuator_controls_0
             control[0..3] (5), vehicle_torque_setpoint xyz and −vehicle_thrust_setpoint
             xyz[2] (4)
sp_*         vehicle_rates_setpoint roll/pitch/yaw (0)
u_thrust     also the thrust setpoints: vehicle_rates_setpoint thrust (old) / −thrust_body[2],
             vehicle_attitude_setpoint thrust / −thrust_body[2] (6: after every other
             thrust command; used with rate or attitude setpoints as inputs)
m1…m8        actuator_motors control[0..7] (0), actuator_outputs output[0..7] PWM,
             RC range (1000–2000 µs) → 0…1 (1)
alt          distance_sensor current_distance, downward (orientation 25), where
             signal_quality ≠ 0 and within min/max_distance (0), vehicle_local_position
             dist_bottom where dist_bottom_valid (1), −z where z_valid (5); then judged by
             content (:mod:`etsid.ingest.source_check`)
vx vy vz     vehicle_local_position (0), where v_xy_valid / v_z_valid
vbat         battery_status voltage_filtered_v (0), voltage_v (1)
============ ============================================================================

ULog has no writer in pyulog, so ULog is not part of the cross-format test set.
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import numpy as np

from etsid.errors import IngestError
from etsid.files import open_binary
from etsid.frames import quat_to_euler
from etsid.ingest import ulog_clean
from etsid.ingest.base import Channel, Issue, RawLog, ReadOptions, Signal
from etsid.ingest.damage import stream_gap_note
from etsid.ingest.rc import motor_from_pwm, stick_from_pwm
from etsid.ingest.vehicle import mav_type_name, px4_version
from etsid.progress import progress

TOPICS = (
    "vehicle_angular_velocity", "vehicle_attitude", "sensor_combined",
    "manual_control_setpoint", "input_rc", "vehicle_rates_setpoint", "actuator_controls_0",
    "vehicle_torque_setpoint", "vehicle_thrust_setpoint", "actuator_motors",
    "actuator_outputs", "vehicle_local_position", "distance_sensor", "battery_status",
    "vehicle_gps_position", "sensor_gps", "vehicle_land_detected", "sensor_gyro",
    "sensor_accel", "vehicle_attitude_setpoint",
)
SAMPLE_TIME = ("vehicle_angular_velocity", "vehicle_attitude", "vehicle_local_position",
               "sensor_gyro", "sensor_accel")
COMMAND_NOTE = "controller torque/thrust commands, not pilot sticks"


class Topic:
    """Fields (name → array) and times (s) of one topic instance."""

    def __init__(self, name: str, data: dict[str, np.ndarray]) -> None:
        self.name, self.data = name, data
        key = "timestamp_sample" if name in SAMPLE_TIME and "timestamp_sample" in data \
            else "timestamp"
        self.t = data[key].astype(np.float64) * 1e-6

    def has(self, field: str) -> bool:
        return field in self.data

    def f(self, field: str, scale: float = 1.0) -> np.ndarray:
        return self.data[field].astype(np.float64) * scale

    def sig(self, column: str, field: str, prio: int, scale: float = 1.0) -> Signal:
        return Signal(column, self.t, self.f(field, scale), f"{self.name}.{field}", prio)


def _sticks(topics: dict[str, Topic], options: ReadOptions, repaired: list[Issue]
            ) -> list[Signal]:
    out: list[Signal] = []
    if (d := topics.get("manual_control_setpoint")) is not None:
        if d.has("valid"):
            keep = d.data["valid"] != 0
            d = Topic(d.name, {k: v[keep] for k, v in d.data.items()})
        if d.has("roll"):  # PX4 ≥ 1.14
            out += [d.sig("u_roll", "roll", 0), d.sig("u_pitch", "pitch", 0),
                    d.sig("u_yaw", "yaw", 0)]
            if d.has("throttle"):
                out.append(Signal("u_thrust", d.t, 0.5 * (d.f("throttle") + 1.0),
                                  f"{d.name}.throttle", 0))
        elif d.has("x"):
            out += [d.sig("u_roll", "y", 0), d.sig("u_pitch", "x", 0), d.sig("u_yaw", "r", 0),
                    d.sig("u_thrust", "z", 0)]
    if (d := topics.get("input_rc")) is not None:
        for column, ch in options.rc_map.items():
            name = f"values[{ch - 1}]"
            if d.has(name):
                v = stick_from_pwm(d.data[name], column, f"{d.name}.{name}", options, repaired)
                out.append(Signal(column, d.t, v, f"{d.name}.{name}", 1))
    if (d := topics.get("actuator_controls_0")) is not None:
        for i, column in enumerate(("u_roll", "u_pitch", "u_yaw", "u_thrust")):
            if d.has(f"control[{i}]"):
                out.append(d.sig(column, f"control[{i}]", 5))
    if (d := topics.get("vehicle_torque_setpoint")) is not None:
        for i, column in enumerate(("u_roll", "u_pitch", "u_yaw")):
            if d.has(f"xyz[{i}]"):
                out.append(d.sig(column, f"xyz[{i}]", 4))
    if (d := topics.get("vehicle_thrust_setpoint")) is not None and d.has("xyz[2]"):
        out.append(d.sig("u_thrust", "xyz[2]", 4, -1.0))
    return out


def _motors(topics: dict[str, Topic], options: ReadOptions, repaired: list[Issue]
            ) -> list[Signal]:
    out: list[Signal] = []
    if (d := topics.get("actuator_motors")) is not None:
        out += [d.sig(f"m{i + 1}", f"control[{i}]", 0) for i in range(8)
                if d.has(f"control[{i}]") and np.isfinite(d.data[f"control[{i}]"]).any()]
    if (d := topics.get("actuator_outputs")) is not None:
        n = int(d.data["noutputs"].max()) if d.has("noutputs") and d.t.size else 8
        for i in range(min(n, 8)):
            if d.has(f"output[{i}]"):
                v = motor_from_pwm(d.data[f"output[{i}]"], f"{d.name}.output[{i}]", options,
                                   repaired)
                out.append(Signal(f"m{i + 1}", d.t, v, f"{d.name}.output[{i}]", 1))
    return out


def _setpoints(topics: dict[str, Topic]) -> list[Signal]:
    """Attitude setpoints (rad) and thrust setpoints (0…1) of the attitude/rate loops."""
    out: list[Signal] = []
    if (d := topics.get("vehicle_attitude_setpoint")) is not None:
        if all(d.has(f"q_d[{i}]") for i in range(4)):
            q = [d.f(f"q_d[{i}]") for i in range(4)]
            ok = np.abs(q[0]) + np.abs(q[1]) + np.abs(q[2]) + np.abs(q[3]) > 0
            angles = quat_to_euler(*(np.where(ok, c, np.nan) for c in q))
            out += [Signal(c, d.t, a, f"{d.name}.q_d", 0)
                    for c, a in zip(("sp_roll", "sp_pitch", "sp_yaw"), angles, strict=True)]
        out += [d.sig(c, f, 1) for c, f in (("sp_roll", "roll_body"), ("sp_pitch", "pitch_body"),
                                            ("sp_yaw", "yaw_body")) if d.has(f)]
    for name in ("vehicle_rates_setpoint", "vehicle_attitude_setpoint"):
        if (d := topics.get(name)) is not None:
            if d.has("thrust_body[2]"):
                out.append(d.sig("u_thrust", "thrust_body[2]", 6, -1.0))
            elif d.has("thrust"):
                out.append(d.sig("u_thrust", "thrust", 6))
    return out


def _valid_only(sig: Signal, d: Topic, flag: str) -> Signal:
    """``sig`` blanked (NaN) where the topic's validity ``flag`` is 0, when it has one."""
    if d.has(flag) and np.any(d.data[flag] == 0):
        sig.values = np.where(d.data[flag] != 0, sig.values, np.nan)
    return sig


def _position(topics: dict[str, Topic]) -> list[Signal]:
    out: list[Signal] = []
    if (d := topics.get("vehicle_local_position")) is not None:
        for c in ("vx", "vy", "vz"):
            if d.has(c):
                out.append(_valid_only(d.sig(c, c, 0), d, "v_z_valid" if c == "vz"
                                       else "v_xy_valid"))
        if d.has("z"):
            out.append(_valid_only(d.sig("alt", "z", 5, -1.0), d, "z_valid"))
        if d.has("dist_bottom"):
            v = d.f("dist_bottom")
            if d.has("dist_bottom_valid"):
                v[d.data["dist_bottom_valid"] == 0] = np.nan
            if np.isfinite(v).any():
                out.append(Signal("alt", d.t, v, f"{d.name}.dist_bottom", 1))
    if (d := topics.get("distance_sensor")) is not None and d.has("current_distance"):
        v = d.f("current_distance")
        if d.has("orientation"):
            v[d.data["orientation"] != 25] = np.nan
        if d.has("signal_quality"):  # 0 = invalid signal, −1 unknown, 1…100 quality
            v[d.data["signal_quality"] == 0] = np.nan
        if d.has("min_distance") and d.has("max_distance"):
            with np.errstate(invalid="ignore"):
                v[(v < d.f("min_distance")) | (v > d.f("max_distance"))] = np.nan
        if np.isfinite(v).any():
            out.append(Signal("alt", d.t, v, f"{d.name}.current_distance", 0))
    return out


def signals(topics: dict[str, Topic], options: ReadOptions, repaired: list[Issue]
            ) -> list[Signal]:
    """Candidate signals of the decoded ``topics``; PWM samples clipped are noted in
    ``repaired``."""
    out: list[Signal] = []
    if (d := topics.get("vehicle_angular_velocity")) is not None:
        out += [d.sig(c, f"xyz[{i}]", 0) for i, c in enumerate("pqr")]
    if (d := topics.get("vehicle_attitude")) is not None:
        angles = quat_to_euler(*(d.f(f"q[{i}]") for i in range(4)))
        out += [Signal(c, d.t, a, f"{d.name}.q", 0)
                for c, a in zip(("roll", "pitch", "yaw"), angles, strict=True)]
    if (d := topics.get("sensor_combined")) is not None:
        out += [d.sig(c, f"gyro_rad[{i}]", 2) for i, c in enumerate("pqr")]
        out += [d.sig(c, f"accelerometer_m_s2[{i}]", 0)
                for i, c in enumerate(("ax", "ay", "az"))]
    if (d := topics.get("vehicle_rates_setpoint")) is not None:
        out += [d.sig(c, f, 0) for c, f in (("sp_p", "roll"), ("sp_q", "pitch"), ("sp_r", "yaw"))
                if d.has(f)]
    out += _setpoints(topics)
    if (d := topics.get("sensor_gyro")) is not None:
        out += [d.sig(c, f, 1) for c, f in zip("pqr", "xyz", strict=True) if d.has(f)]
    if (d := topics.get("sensor_accel")) is not None:
        out += [d.sig(c, f, 1) for c, f in zip(("ax", "ay", "az"), "xyz", strict=True)
                if d.has(f)]
    if (d := topics.get("vehicle_land_detected")) is not None and d.has("landed"):
        out.append(d.sig("landed", "landed", 0))
        stages = [d.f(f) for f in ("ground_contact", "maybe_landed") if d.has(f)]
        if stages:
            out.append(Signal("ground_contact", d.t, np.fmax.reduce(stages),
                              f"{d.name}.ground_contact", 0))
    if (d := topics.get("battery_status")) is not None:
        out += [d.sig("vbat", f, k) for k, f in enumerate(("voltage_filtered_v", "voltage_v"))
                if d.has(f)]
    return (out + _sticks(topics, options, repaired) + _motors(topics, options, repaired)
            + _position(topics))


def motor_layout(params: dict[str, object]) -> dict[str, object] | None:
    """The motor layout of PX4's control allocation (PX4 ≥ 1.13): ``CA_ROTOR_COUNT`` rotors,
    rotor i at ``CA_ROTOR{i}_PX/_PY`` (m, FRD) spinning ``sign(CA_ROTOR{i}_KM)`` (positive =
    counter-clockwise seen from above). Rotor i is ``actuator_motors.control[i]`` (``topic``);
    the PWM ``actuator_outputs`` follow the output functions, not this order. None without
    the parameters."""
    try:
        n = int(params["CA_ROTOR_COUNT"])  # type: ignore[call-overload]
        rows = [(float(params[f"CA_ROTOR{i}_PX"]), float(params[f"CA_ROTOR{i}_PY"]),  # type: ignore[arg-type]
                 float(np.sign(float(params.get(f"CA_ROTOR{i}_KM", 0.05)))))  # type: ignore[arg-type]
                for i in range(n)]
    except (KeyError, TypeError, ValueError):
        return None
    if n < 4:
        return None
    x, y, spin = (list(v) for v in zip(*rows, strict=True))
    return {"x": x, "y": y, "spin": spin, "topic": "actuator_motors"}


def _start_time(topics: dict[str, Topic]) -> float | None:
    for name in ("sensor_gps", "vehicle_gps_position"):
        d = topics.get(name)
        if d is not None and d.has("time_utc_usec"):
            ok = np.flatnonzero(d.data["time_utc_usec"] > 0)
            if ok.size:
                i = int(ok[0])
                return float(d.data["time_utc_usec"][i] * 1e-6 - d.data["timestamp"][i] * 1e-6)
    return None


def _parse(path: Path, names: list[str], cleaned: ulog_clean.Cleaned) -> object:
    from pyulog import ULog

    try:
        # the file is opened here and closed on every path: pyulog, given a name, leaves
        # its handle open when it gives up on a damaged file (a ResourceWarning later)
        with (io.BytesIO(ulog_clean.payload(path, cleaned)) if cleaned.changed
              else open_binary(path, "log", IngestError)) as handle, \
                contextlib.redirect_stdout(io.StringIO()), \
                contextlib.redirect_stderr(io.StringIO()):
            return ULog(handle, message_name_filter_list=names)
    except Exception as err:  # pyulog raises many types on broken files
        first = str(err).splitlines()[0][:200] if str(err) else type(err).__name__
        raise IngestError(f"{path}: not a readable ULog file ({first})") from err


def _clean_notes(path: Path, cleaned: ulog_clean.Cleaned, raw: RawLog) -> None:
    """Notes on what :func:`ulog_clean.clean` left out (stretches skipped are noted with
    pyulog's own corruption note)."""
    if cleaned.tail:
        start = path.stat().st_size - cleaned.tail
        raw.dropped.append(Issue("bytes that are not ULog messages, at the end", cleaned.tail,
                                 ""))
        raw.warnings.append(f"{path.name}: the {cleaned.tail} bytes from byte {start} on are "
                            "not ULog messages and no sync message follows them: skipped")
    if cleaned.recursive:
        names = ", ".join(cleaned.recursive[:5]) + (" …" if len(cleaned.recursive) > 5 else "")
        raw.warnings.append(f"{path.name}: {len(cleaned.recursive)} message format(s) refer "
                            f"to themselves ({names}): the topics using them are skipped")


def ulog_facts(ulog: object) -> dict[str, str]:
    """Vehicle, autopilot, firmware and hardware as the ULog's info messages and the
    ``MAV_TYPE`` parameter state them (:mod:`etsid.ingest.vehicle`)."""
    info = getattr(ulog, "msg_info_dict", {}) or {}
    params = getattr(ulog, "initial_parameters", {}) or {}
    facts: dict[str, str] = {}
    name = info.get("sys_name")
    if isinstance(name, str) and name.strip():
        facts["autopilot"] = name.strip()
    release = info.get("ver_sw_release")
    version = px4_version(release) if isinstance(release, int) else None
    git = info.get("ver_sw")
    git = git[:8] if isinstance(git, str) and re.fullmatch(r"[0-9a-fA-F]{7,}", git) else None
    if version or git:
        facts["firmware"] = " ".join(filter(None, (version, f"({git})" if git else None)))
    hardware = info.get("ver_hw")
    if isinstance(hardware, str) and hardware.strip():
        facts["hardware"] = hardware.strip()
    mav_type = params.get("MAV_TYPE")
    vehicle = mav_type_name(mav_type) if isinstance(mav_type, (int, float)) else None
    if vehicle:
        facts["vehicle"] = vehicle
    return facts


def read(path: Path, options: ReadOptions) -> RawLog:
    """Read a PX4 ULog into a :class:`RawLog` (see the module docstring)."""
    extra_topics = [o.topic for o in options.field_requests() if o.topic not in TOPICS]
    with progress(path.stat().st_size, f"reading {path.name}", options.progress) as bar:
        cleaned = ulog_clean.clean(path)
        ulog = _parse(path, [t for t in list(TOPICS) + extra_topics
                             if t not in cleaned.recursive], cleaned)
        bar.update(path.stat().st_size)
    raw = RawLog(path=path, format="ulog")
    _clean_notes(path, cleaned, raw)
    topics: dict[str, Topic] = {}
    for d in sorted(ulog.data_list, key=lambda d: (d.name, d.multi_id)):  # type: ignore[attr-defined]
        if d.multi_id == 0 and "timestamp" in d.data and d.data["timestamp"].size:
            topics[d.name] = Topic(d.name, d.data)
    raw.signals = signals(topics, options, raw.repaired)
    for o in options.field_requests():
        d = topics.get(o.topic)
        if d is None or not d.has(o.field or ""):
            have = ", ".join(d.data) if d is not None else "topic not in log"
            raise IngestError(f"{path}: --map {o.text}: no such field ({have})")
        raw.signals.append(Signal(o.column, d.t, d.f(o.field or ""), f"{o.topic}.{o.field}",
                                  -1))
    raw.signals = [s for s in raw.signals if np.count_nonzero(np.isfinite(s.values)) >= 2]
    raw.start_time = _start_time(topics)
    layout = motor_layout(getattr(ulog, "initial_parameters", {}) or {})
    if layout is not None:
        raw.extra["motor_layout"] = layout
    autostart = (getattr(ulog, "initial_parameters", {}) or {}).get("SYS_AUTOSTART")
    if isinstance(autostart, int | float) and autostart > 0:
        raw.extra["sys_autostart"] = int(autostart)   # the airframe (etsid.ingest.px4_airframes)
    columns: dict[str, list[str]] = {}
    for sig in raw.signals:
        cols = columns.setdefault(sig.topic, [])
        if sig.column not in cols:
            cols.append(sig.column)
    for d in sorted(ulog.data_list, key=lambda d: (d.name, d.multi_id)):  # type: ignore[attr-defined]
        t = Topic(d.name, d.data).t if "timestamp" in d.data else np.empty(0)
        name = d.name if d.multi_id == 0 else f"{d.name}.{d.multi_id}"
        note = COMMAND_NOTE if d.name in ("actuator_controls_0", "vehicle_torque_setpoint",
                                          "vehicle_thrust_setpoint") else ""
        if d.name in ("vehicle_attitude_setpoint", "vehicle_rates_setpoint"):
            note = "setpoints: fill only sp_* and u_thrust, never a measured column"
        if d.multi_id:
            note = "instance > 0, not used"
        raw.channels.append(Channel(name, d.name, int(t.size),
                                    float(t[0]) if t.size else None,
                                    float(t[-1]) if t.size else None,
                                    columns.get(d.name, []) if d.multi_id == 0 else [], note))
    raw.extra["topics_parsed"] = len(TOPICS) + len(extra_topics)
    raw.extra.update(ulog_facts(ulog))
    cut = cleaned.cut
    if cut:
        raw.dropped.append(Issue("bytes of a truncated last message", cut, ""))
        raw.warnings.append(f"{path.name}: file is truncated: skipped the last {cut} bytes "
                            "(an incomplete message)")
    if getattr(ulog, "file_corruption", False) or cleaned.skipped:
        what = "file is corrupt; pyulog skipped the damaged bytes and kept the readable messages"
        if cleaned.skipped:
            nbytes = sum(n for _, n in cleaned.skipped)
            where = ", ".join(str(a) for a, _ in cleaned.skipped[:5])
            raw.dropped.append(Issue("bytes that are no ULog messages", nbytes, ""))
            what = (f"file is corrupt; skipped {nbytes} bytes that are no ULog messages at "
                    f"byte {where}{' …' if len(cleaned.skipped) > 5 else ''} and kept the "
                    "readable messages")
        raw.warnings.append(stream_gap_note(
            path.name, what, [t.t for t in topics.values()],
            [(d.timestamp * 1e-6 - 0.01, d.timestamp * 1e-6 + d.duration * 1e-3 + 0.01)
             for d in getattr(ulog, "dropouts", [])]))
    for dropped in getattr(ulog, "dropouts", []):
        raw.warnings.append(f"logger dropout of {dropped.duration} ms at "
                            f"{dropped.timestamp * 1e-6:.3f} s")
    return raw
