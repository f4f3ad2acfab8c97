"""ArduPilot DataFlash logs (``.bin``) via pymavlink's ``DFReader_binary``.

``DFReader_binary`` memory-maps the whole file and indexes every message (one Python
loop over the file, and one list entry per message: memory grows with the log, which
is accepted for this format). The needed message types are then decoded in blocks with
numpy, from the FMT definitions DFReader parsed (struct layout, the format's own
multipliers such as ×0.01 for ``c``/``C``), instead of one Python object per message.

Columns, units and priorities (lower wins):

============ ============================================================================
column       candidates (priority)
============ ============================================================================
p q r        RATE R/P/Y deg/s, cdeg/s in 3.x (0), IMU GyrX… rad/s (2), IMU2 (3), IMU3 (4); RATE is
             ~10 Hz in most logs: the ingest rule "rate beats priority"
             (:func:`etsid.ingest.mapping.prefer_rate`) then takes IMU
roll…        ATT Roll/Pitch/Yaw deg (0; Yaw 0…360 wrapped to ±180)
sp_roll…     ATT DesRoll/DesPitch/DesYaw deg (0; DesYaw wrapped to ±180): attitude setpoints
ax ay az     IMU AccX… m/s² (0), IMU2 (1), IMU3 (2)
u_*          RCIN C1… via ``rc_map`` (0); RATE ROut/POut/YOut, AOut (5: controller outputs);
             u_thrust also CTUN ThrOut / ThO from 3.4 (7: the throttle sent to the motors,
             0…1000 up to 3.3, 0…1 later)
sp_*         RATE RDes/PDes/YDes deg/s (0)
m1…m8        RCOU C1…C8, RC range (1000–2000 µs) → 0…1 (0)
alt          RFND Dist (m; old logs' Dist1 in cm, decided from FMTU units or the field's
             integer type), downward (Orient 25) when the field exists (0);
             CTUN BarAlt/BAlt m (1), BARO Alt m (2): barometric height above arming
vx vy vz     XKF1 VN/VE/VD m/s (0: EKF3, 4.1+), NKF1 (1: EKF2, 3.4–4.0), EKF1 (2: the 3.x
             EKF), core 0 (``C``); VN/VE kept only where the last GPS report has a 3D fix
             (Status ≥ 3): without one the EKF holds a constant position and its horizontal
             velocity is no measurement (a log without GPS has vz only)
vbat         BAT Volt (0)
landed       EV Id (ArduPilot ``LogEvent``): with a take-off event in the log, a land
             detector (0): LAND_COMPLETE 18, DISARMED 11, ARMED 10, AUTO_ARMED 15 → 1
             (on the ground), NOT_LANDED 28 or TAKEOFF 16 (3.1–3.2) → 0; otherwise an
             armed state (1): DISARMED 11
             → 1, ARMED 10 / AUTO_ARMED 15 → 0 (source ``EV.Id (armed)``). ARM ArmState
             (2, armed state: 0 → 1, 1 → 0). Events are sparse: the state is sampled at
             :data:`EVENT_STATE_HZ` from the first event to the end of the log (held).
============ ============================================================================

Older generations (3.x: untimed EV, GPS time of week, RATE units, RCOU ``Ch1…``):
:mod:`etsid.ingest.dataflash_legacy`.

Instanced messages (``I``, ``Instance``, ``Inst`` fields) keep instance 0. Time is
``TimeUS`` (µs since boot; ``TimeMS`` in old logs). ``start_time`` comes from the first
GPS fix (``GWk``/``GMS``) when there is one. A truncated file yields its complete
messages and a warning with the number of skipped bytes.
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from etsid.errors import IngestError
from etsid.files import check
from etsid.ingest import dataflash_index
from etsid.ingest.base import Channel, Issue, RawLog, ReadOptions, Signal
from etsid.ingest.damage import stream_gap_note
from etsid.ingest.dataflash_legacy import (
    BOOT_TIME_FIELDS,
    baro_altitude,
    ctun_throttle_scale,
    file_times,
    out_scales,
    rate_scale,
)
from etsid.ingest.rc import motor_from_pwm, stick_from_pwm
from etsid.ingest.vehicle import banner_facts, decode_text, first_banner
from etsid.progress import progress

DEG = np.pi / 180.0
EKF_VELOCITY = ("XKF1", "NKF1", "EKF1")
"""Messages with the EKF's NED velocity VN/VE/VD, m/s, best first (EKF3 4.1+, EKF2 3.4–4.0,
the 3.x EKF); their ``C`` field is the core."""
GPS_3D_FIX = 3
"""GPS ``Status`` of a 3D fix (AP_GPS::GPS_OK_FIX_3D; 4 DGPS, 5–6 RTK are better)."""
NEEDED = ("ATT", "RATE", "IMU", "IMU2", "IMU3", "RCIN", "RCOU", "BAT", "RFND", "GPS", "EV",
          "ARM", "CTUN", "BARO", *EKF_VELOCITY)
EV_ARMED, EV_DISARMED, EV_AUTO_ARMED = 10, 11, 15
EV_TAKEOFF, EV_LAND_COMPLETE, EV_NOT_LANDED = 16, 18, 28
"""ArduCopter ``LogEvent`` ids (``DATA_*`` in ArduCopter/defines.h, AP_Logger since 4.x),
the ones that say armed or landed. The numbers are the same in every generation 3.1–4.x;
what a generation writes differs (:func:`_landed`): ``DATA_TAKEOFF`` (16) exists up to 3.2,
where the manual-throttle modes log it at lift-off and never clear the land-complete flag
(so a 3.1 flight in Stabilize has a LAND_COMPLETE and no NOT_LANDED); 16 is unused later."""
EV_AIR = (EV_NOT_LANDED, EV_TAKEOFF)
"""Events that mean the vehicle left the ground (in any generation)."""
EV_GROUND = (EV_LAND_COMPLETE, EV_DISARMED, EV_ARMED, EV_AUTO_ARMED)
"""Events that mean it is on the ground (arming happens there)."""
EVENT_STATE_HZ = 10.0
"""Rate at which a state known from events (EV, ARM) is sampled, Hz."""
_NP = {"b": "i1", "B": "u1", "h": "<i2", "H": "<u2", "i": "<i4", "I": "<u4", "q": "<i8",
       "Q": "<u8", "f": "<f4", "d": "<f8", "s": "S"}
NOISE_BYTES = 1 << 16
"""What DFReader printed is kept up to this many bytes (its messages are not needed)."""
GPS_EPOCH = 315964800.0
GPS_LEAP_S = 18.0


def _dtype(fmt: object) -> np.dtype:
    tokens = re.findall(r"(\d*)([a-zA-Z])", fmt.msg_struct.lstrip("<"))  # type: ignore[attr-defined]
    fields = []
    for name, (count, char) in zip(fmt.columns, tokens, strict=True):  # type: ignore[attr-defined]
        n = int(count) if count else 1
        if char == "s":
            fields.append((name, f"S{n}"))
        elif n > 1:
            fields.append((name, _NP[char], (n,)))
        else:
            fields.append((name, _NP[char]))
    return np.dtype(fields)


@contextlib.contextmanager
def _captured_output() -> Iterator[list[str]]:
    """Capture what DFReader prints, from Python and from its C indexer (fds 1 and 2)."""
    text: list[str] = []
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        try:
            yield text
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            tmp.seek(0)
            text.append(tmp.read(NOISE_BYTES).decode(errors="replace"))


def _reader_class() -> type:
    from pymavlink import DFReader

    dataflash_index.install()

    class IndexOnly(DFReader.DFReader_binary):  # type: ignore[misc]
        """DFReader_binary without its clock set-up pass, which parses every message in
        Python when a log has no GPS (etsid reads TimeUS itself), and with etsid's
        resynchronising indexer (:mod:`etsid.ingest.dataflash_index`)."""

        def init_clock(self) -> None:
            self.clock = DFReader.DFReaderClock_usec()

        def init_arrays(self, progress_callback: object = None) -> None:
            self.init_arrays_fast(progress_callback)  # never the per-byte Python indexer

        def __init__(self, *args: object, **kwargs: object) -> None:
            self.index_stats = dataflash_index.IndexStats()
            token = dataflash_index.STATS.set(self.index_stats)
            try:
                super().__init__(*args, **kwargs)
            except BaseException:  # a broken file: do not leak the handle DFReader opened
                for name in ("data_map", "filehandle"):
                    with contextlib.suppress(Exception):
                        getattr(self, name).close()
                raise
            finally:
                dataflash_index.STATS.reset(token)

    return IndexOnly


def _open(path: Path) -> tuple[object, str]:
    try:
        with _captured_output() as noise:
            reader = _reader_class()(str(check(path, "log", IngestError)),
                                     zero_time_base=False)
    except Exception as err:  # DFReader raises bare Exceptions on broken files
        raise IngestError(f"{path}: not a readable DataFlash log ({err})") from err
    return reader, "".join(noise)


class _Decoded:
    """Records of one message type (instance 0), with their times in s."""

    def __init__(self, name: str, rec: np.ndarray, t: np.ndarray, fmt: object) -> None:
        self.name, self.rec, self.t, self.fmt = name, rec, t, fmt

    def f(self, field: str, scale: float = 1.0) -> np.ndarray:
        return self.rec[field].astype(np.float64) * scale

    def has(self, field: str) -> bool:
        return field in (self.rec.dtype.names or ())


def _decode(reader: object, data: np.ndarray, name: str, raw: RawLog) -> _Decoded | None:
    mtype = reader.name_to_id.get(name)  # type: ignore[attr-defined]
    if mtype is None or not reader.counts[mtype]:  # type: ignore[attr-defined]
        return None
    fmt = reader.formats[mtype]  # type: ignore[attr-defined]
    dtype = _dtype(fmt)
    offs = np.asarray(reader.offsets[mtype], dtype=np.int64)  # type: ignore[attr-defined]
    offs = offs[offs + fmt.len <= data.size]
    if not offs.size or dtype.itemsize != fmt.len - 3:
        return None
    rec = data[(offs + 3)[:, None] + np.arange(dtype.itemsize)].view(dtype).ravel()
    for inst in ("I", "Instance", "Inst") + (("C",) if name in EKF_VELOCITY else ()):
        if inst in (dtype.names or ()):
            rec = rec[rec[inst] == rec[inst].min()]
            break
    out = np.empty(rec.shape, np.dtype([(n, "<f8") if rec.dtype[n].kind in "iuf" and
                                        not rec.dtype[n].shape else (n, rec.dtype[n])
                                        for n in rec.dtype.names]))
    with np.errstate(invalid="ignore", over="ignore"):
        for i, n in enumerate(rec.dtype.names):
            mult = fmt.msg_mults[i] if i < len(fmt.msg_mults) else None
            out[n] = rec[n] * mult if mult is not None and not rec.dtype[n].shape else rec[n]
    if BOOT_TIME_FIELDS.get(name) in out.dtype.names:  # 3.x GPS: TimeMS is GPS time
        t = out[BOOT_TIME_FIELDS[name]] * 1e-3
    elif "TimeUS" in out.dtype.names:
        t = out["TimeUS"] * 1e-6
    elif "TimeMS" in out.dtype.names:
        t = out["TimeMS"] * 1e-3
    elif out.size == offs.size and (untimed := file_times(reader, data, offs)) is not None:
        t = untimed  # 3.x EV/ERR: no time field (etsid.ingest.dataflash_legacy)
    else:
        return None
    late = int(np.count_nonzero(t < np.maximum.accumulate(t))) if t.size else 0
    if late:
        order = np.argsort(t, kind="stable")
        out, t = out[order], t[order]
        raw.repaired.append(Issue("out-of-order timestamp, re-sorted", late, name))
    return _Decoded(name, out, t, fmt)


def _xyz(d: _Decoded, fields: tuple[str, ...], columns: tuple[str, ...], scale: float,
         prio: int) -> list[Signal]:
    return [Signal(c, d.t, d.f(f, scale), f"{d.name}.{f}", prio)
            for f, c in zip(fields, columns, strict=True) if d.has(f)]


def _signals(msgs: dict[str, _Decoded], options: ReadOptions, repaired: list[Issue],
             dropped: list[Issue]) -> list[Signal]:
    out: list[Signal] = []
    if (d := msgs.get("ATT")) is not None:
        out += _xyz(d, ("Roll", "Pitch"), ("roll", "pitch"), DEG, 0)
        if d.has("Yaw"):
            yaw = np.angle(np.exp(1j * d.f("Yaw", DEG)))
            out.append(Signal("yaw", d.t, yaw, "ATT.Yaw", 0))
        out += _xyz(d, ("DesRoll", "DesPitch"), ("sp_roll", "sp_pitch"), DEG, 0)
        if d.has("DesYaw"):
            out.append(Signal("sp_yaw", d.t, np.angle(np.exp(1j * d.f("DesYaw", DEG))),
                              "ATT.DesYaw", 0))
    if (d := msgs.get("RATE")) is not None:
        imu = msgs.get("IMU")
        unit = (rate_scale(d.t, d.f("R"), imu.t, imu.f("GyrX"))[0]
                if d.has("R") and imu is not None and imu.has("GyrX") else DEG)
        out += _xyz(d, ("R", "P", "Y"), ("p", "q", "r"), unit, 0)
        out += _xyz(d, ("RDes", "PDes", "YDes"), ("sp_p", "sp_q", "sp_r"), unit, 0)
        outs = [f for f in ("ROut", "POut", "YOut", "AOut") if d.has(f)]
        scale = out_scales({f: d.f(f) for f in outs})
        for f, c in zip(("ROut", "POut", "YOut", "AOut"),
                        ("u_roll", "u_pitch", "u_yaw", "u_thrust"), strict=True):
            if f in scale:
                out.append(Signal(c, d.t, d.f(f, scale[f]), f"RATE.{f}", 5))
    for k, name in enumerate(("IMU", "IMU2", "IMU3")):
        if (d := msgs.get(name)) is not None:
            out += _xyz(d, ("GyrX", "GyrY", "GyrZ"), ("p", "q", "r"), 1.0, 2 + k)
            out += _xyz(d, ("AccX", "AccY", "AccZ"), ("ax", "ay", "az"), 1.0, k)
    if (d := msgs.get("RCIN")) is not None:
        for column, ch in options.rc_map.items():
            if d.has(f"C{ch}"):
                v = stick_from_pwm(d.rec[f"C{ch}"], column, f"RCIN.C{ch}", options, repaired)
                out.append(Signal(column, d.t, v, f"RCIN.C{ch}", 0))
    if (d := msgs.get("RCOU")) is not None:
        for i in range(1, 9):
            f = f"C{i}" if d.has(f"C{i}") else f"Ch{i}"  # 3.x: Ch1…
            if d.has(f) and (d.rec[f] != 0).any():
                v = motor_from_pwm(d.rec[f], f"RCOU.{f}", options, repaired)
                out.append(Signal(f"m{i}", d.t, v, f"RCOU.{f}", 0))
    out += _velocity(msgs, dropped)
    if (d := msgs.get("BAT")) is not None and d.has("Volt"):
        out.append(Signal("vbat", d.t, d.f("Volt"), "BAT.Volt", 0))
    if (d := msgs.get("RFND")) is not None:
        out += _rangefinder(d)
    for name, d, field, prio in baro_altitude(msgs.get("CTUN"), msgs.get("BARO")):
        out.append(Signal("alt", d.t, d.f(field), f"{name}.{field}", prio))
    if (d := msgs.get("CTUN")) is not None:
        for field in ("ThrOut", "ThO"):  # ThO from 3.4 on
            if d.has(field):
                v = d.f(field)
                out.append(Signal("u_thrust", d.t, v * ctun_throttle_scale(v), f"CTUN.{field}",
                                  7))
                break
    return out + _landed(msgs)


def _velocity(msgs: dict[str, _Decoded], dropped: list[Issue]) -> list[Signal]:
    """vx, vy, vz (NED, m/s) from the EKF's velocity (:data:`EKF_VELOCITY`); VN/VE only
    where the last GPS report before a sample has a 3D fix (the others counted in
    ``dropped``; none at all in a log without GPS)."""
    gps = msgs.get("GPS")
    out: list[Signal] = []
    for prio, name in enumerate(EKF_VELOCITY):
        d = msgs.get(name)
        if d is None or not all(d.has(f) for f in ("VN", "VE", "VD")) or not d.t.size:
            continue
        fixed = np.zeros(d.t.size, dtype=bool)
        if gps is not None and gps.has("Status") and gps.t.size:
            last = np.searchsorted(gps.t, d.t, side="right") - 1
            fixed = (last >= 0) & (gps.rec["Status"][np.maximum(last, 0)] >= GPS_3D_FIX)
        for field, column in (("VN", "vx"), ("VE", "vy")):
            if fixed.any():
                out.append(Signal(column, d.t[fixed], d.f(field)[fixed], f"{name}.{field}",
                                  prio))
                if not fixed.all():
                    dropped.append(Issue("no GPS 3D fix", int(np.sum(~fixed)),
                                         f"{name}.{field}"))
        out.append(Signal("vz", d.t, d.f("VD"), f"{name}.VD", prio))
    return out


def _held_state(t: np.ndarray, v: np.ndarray, t_end: float) -> tuple[np.ndarray, np.ndarray]:
    """A state changed by events at ``t`` sampled regularly from the first event to
    ``t_end``, each sample the value of the last event at or before it."""
    grid = np.arange(t[0], max(t_end, t[-1]) + 0.5 / EVENT_STATE_HZ, 1.0 / EVENT_STATE_HZ)
    grid = np.union1d(grid, t)
    return grid, v[np.searchsorted(t, grid, side="right") - 1]


def _landed(msgs: dict[str, _Decoded]) -> list[Signal]:
    """``landed`` from EV events (land detector or armed state) and ARM (armed state).

    The events are a land detector only when the log holds a take-off event
    (:data:`EV_AIR`: NOT_LANDED, or 3.1–3.2's TAKEOFF): a LAND_COMPLETE without one (3.1–3.2
    in manual-throttle modes, or a log cut before the take-off) would say "on the ground"
    for a whole flight; such a log's events are read as its armed state instead."""
    out: list[Signal] = []
    t_end = max((float(d.t[-1]) for d in msgs.values() if d.t.size), default=0.0)
    if (d := msgs.get("EV")) is not None and d.has("Id"):
        ids = d.rec["Id"].astype(np.int64)
        if np.isin(ids, EV_AIR).any():  # a land detector needs a take-off to be one
            ground, air, source, prio = EV_GROUND, EV_AIR, "EV.Id", 0
        else:
            ground, air, source, prio = ((EV_DISARMED,), (EV_ARMED, EV_AUTO_ARMED),
                                         "EV.Id (armed)", 1)
        v = np.where(np.isin(ids, ground), 1.0, np.where(np.isin(ids, air), 0.0, np.nan))
        ok = np.isfinite(v)
        if ok.any():
            out.append(Signal("landed", *_held_state(d.t[ok], v[ok], t_end), source, prio))
    if (d := msgs.get("ARM")) is not None and d.has("ArmState") and d.t.size:
        v = np.where(d.rec["ArmState"] > 0, 0.0, 1.0)
        out.append(Signal("landed", *_held_state(d.t, v, t_end), "ARM.ArmState", 2))
    return out


def _rangefinder(d: _Decoded) -> list[Signal]:
    field = "Dist" if d.has("Dist") else "Dist1" if d.has("Dist1") else None
    if field is None:
        return []
    idx = d.fmt.columns.index(field)  # type: ignore[attr-defined]
    unit = d.fmt.get_unit(field)  # type: ignore[attr-defined]
    if unit == "cm":
        scale = 0.01
    elif unit == "m":
        scale = 1.0
    else:  # no FMTU: a raw integer field without its own multiplier holds cm
        raw_int = d.fmt.msg_fmts[idx] in "bBhHiI" and d.fmt.msg_mults[idx] is None  # type: ignore[attr-defined]
        scale = 0.01 if raw_int else 1.0
    v = d.f(field, scale)
    if d.has("Orient"):
        v[d.rec["Orient"] != 25] = np.nan
    return [Signal("alt", d.t, v, f"RFND.{field}", 0)] if np.isfinite(v).any() else []


def _start_time(msgs: dict[str, _Decoded]) -> float | None:
    d = msgs.get("GPS")
    if d is None or not (d.has("GWk") and d.has("GMS")):
        return None
    ok = d.rec["GWk"] > 0
    if d.has("Status"):
        ok &= d.rec["Status"] >= 3
    if not ok.any():
        return None
    i = int(np.argmax(ok))
    unix = GPS_EPOCH + d.rec["GWk"][i] * 604800.0 + d.rec["GMS"][i] * 1e-3 - GPS_LEAP_S
    return float(unix - d.t[i])


def read(path: Path, options: ReadOptions) -> RawLog:
    """Read an ArduPilot DataFlash log into a :class:`RawLog` (see the module docstring)."""
    with progress(path.stat().st_size, f"reading {path.name}", options.progress) as bar:
        reader, noise = _open(path)
        bar.update(path.stat().st_size)
    try:
        data = np.frombuffer(reader.data_map, dtype=np.uint8)  # type: ignore[attr-defined]
        return _read(path, reader, data, noise, options)
    finally:
        del data
        with contextlib.suppress(Exception):
            reader.close()  # type: ignore[attr-defined]
        with contextlib.suppress(Exception):
            reader.filehandle.close()  # type: ignore[attr-defined]  # close() leaves it open


def _read(path: Path, reader: object, data: np.ndarray, noise: str,
          options: ReadOptions) -> RawLog:
    raw = RawLog(path=path, format="bin")
    wanted = list(NEEDED) + [o.topic for o in options.field_requests() if o.topic not in NEEDED]
    msgs: dict[str, _Decoded] = {}
    for name in wanted:
        d = _decode(reader, data, name, raw)
        if d is not None:
            msgs[name] = d
    raw.signals = _signals(msgs, options, raw.repaired, raw.dropped)
    for o in options.field_requests():
        d = msgs.get(o.topic)
        if d is None or not d.has(o.field or ""):
            have = ", ".join(d.rec.dtype.names) if d is not None else "message not in log"
            raise IngestError(f"{path}: --map {o.text}: no such field ({have})")
        if d.rec[o.field or ""].dtype.kind not in "biuf":
            raise IngestError(f"{path}: --map {o.text}: field is not numeric "
                              f"({d.rec[o.field or ''].dtype})")
        raw.signals.append(Signal(o.column, d.t, d.f(o.field or ""), f"{o.topic}.{o.field}",
                                  -1))
    raw.signals = [s for s in raw.signals if np.count_nonzero(np.isfinite(s.values)) >= 2]
    raw.start_time = _start_time(msgs)
    raw.extra.update(_facts(reader, data, path))
    _frame(raw, reader, data, path)
    _catalogue(raw, reader, data, msgs)
    _damage(raw, reader, data, noise, [d.t for d in msgs.values()])
    return raw


BOARD_LINE = re.compile(r"^(\S+)\s+[0-9A-Fa-f]{8}\s+[0-9A-Fa-f]{8}\s+[0-9A-Fa-f]{8}$")
"""The MSG line with the board name and its unique id (``PX4v4 00360029 30365103 …``)."""


def _facts(reader: object, data: np.ndarray, path: Path) -> dict[str, str]:
    """Firmware, autopilot and vehicle from the firmware banner (``VER.FWS`` or the first
    banner ``MSG``), the board from the MSG line with its id (:mod:`etsid.ingest.vehicle`)."""
    scratch = RawLog(path=path, format="bin")  # notes of these decodes are not the log's
    facts: dict[str, str] = {}
    ver = _decode(reader, data, "VER", scratch)
    if ver is not None and "FWS" in (ver.rec.dtype.names or ()) and ver.rec.size:
        facts = banner_facts(decode_text(ver.rec["FWS"][-1]))
    msg = _decode(reader, data, "MSG", scratch)
    lines = ([decode_text(m) for m in msg.rec["Message"]]
             if msg is not None and "Message" in (msg.rec.dtype.names or ()) else [])
    if not facts:
        facts, _ = first_banner(lines)
    for line in lines:
        board = BOARD_LINE.match(line)
        if board:
            facts["hardware"] = board.group(1)
            break
    return dict(sorted(facts.items()))


def _frame(raw: RawLog, reader: object, data: np.ndarray, path: Path) -> None:
    """ArduPilot's frame parameters (last value of each) into ``extra`` (and so the table's
    ``attrs["log"]``): ``frame_class``, ``frame_type`` (ArduCopter ≥ 3.5), ``frame`` (3.x).
    What they mean is :mod:`etsid.ingest.ardupilot_frames`'s; the table's
    ``motor_layout`` stays for mixers with positions."""
    parm = _decode(reader, data, "PARM", RawLog(path=path, format="bin"))
    if parm is None or not (parm.has("Name") and parm.has("Value")):
        return
    for name, value in zip(parm.rec["Name"], parm.rec["Value"], strict=True):
        key = decode_text(name)
        if key in ("FRAME_CLASS", "FRAME_TYPE", "FRAME") and np.isfinite(value):
            raw.extra[key.lower()] = float(value)


def _catalogue(raw: RawLog, reader: object, data: np.ndarray,
               msgs: dict[str, _Decoded]) -> None:
    columns: dict[str, list[str]] = {}
    for sig in raw.signals:
        cols = columns.setdefault(sig.topic, [])
        if sig.column not in cols:
            cols.append(sig.column)
    for mtype, fmt in sorted(reader.formats.items(), key=lambda kv: kv[1].name):  # type: ignore[attr-defined]
        count = reader.counts[mtype] if mtype < len(reader.counts) else 0  # type: ignore[attr-defined]
        if not count:
            continue
        first = last = None
        if fmt.name in msgs and msgs[fmt.name].t.size:
            first, last = float(msgs[fmt.name].t[0]), float(msgs[fmt.name].t[-1])
        elif fmt.columns[:1] == ["TimeUS"] and fmt.msg_struct[1:2] == "Q":
            offs = reader.offsets[mtype]  # type: ignore[attr-defined]
            ends = [o for o in (offs[0], offs[-1]) if o + 11 <= data.size]
            if len(ends) == 2:
                first, last = (float(data[o + 3:o + 11].view("<u8")[0]) * 1e-6 for o in ends)
        raw.channels.append(Channel(fmt.name, "dataflash", int(count), first, last,
                                    columns.get(fmt.name, [])))


def _damage(raw: RawLog, reader: object, data: np.ndarray, noise: str,
            streams: list[np.ndarray]) -> None:
    end = 0
    for mtype, offs in enumerate(reader.offsets):  # type: ignore[attr-defined]
        if offs and mtype in reader.formats:  # type: ignore[attr-defined]
            length = reader.formats[mtype].len  # type: ignore[attr-defined]
            complete = [o for o in offs[-2:] if o + length <= data.size]
            if complete:
                end = max(end, complete[-1] + length)
    if not end:
        raise IngestError(f"{raw.path}: no DataFlash messages found")
    tail = data.size - end
    if tail:
        raw.dropped.append(Issue("bytes after the last complete message", tail, ""))
        raw.warnings.append(f"{raw.path.name}: file is truncated or has trailing garbage: "
                            f"skipped the last {tail} bytes")
    stats = getattr(reader, "index_stats", None) or dataflash_index.IndexStats()
    skipped = stats.skipped_bytes
    bad = len(re.findall(r"bad header|unknown msg type", noise))
    if stats.rejected_fmts:
        at = ", ".join(str(p) for p in stats.rejected_fmts[:5])
        raw.dropped.append(Issue("FMT record of an impossible length or format",
                                 len(stats.rejected_fmts), "FMT"))
        raw.warnings.append(f"{raw.path.name}: skipped {len(stats.rejected_fmts)} FMT "
                            f"record(s) of an impossible length or format at byte {at}"
                            f"{' …' if len(stats.rejected_fmts) > 5 else ''}; read on after "
                            "them")
    if skipped or bad:
        raw.dropped.append(Issue("bytes that are no valid DataFlash message", skipped + bad, ""))
        raw.warnings.append(stream_gap_note(
            raw.path.name, f"skipped {skipped + bad} bytes that are no valid DataFlash message",
            streams))
