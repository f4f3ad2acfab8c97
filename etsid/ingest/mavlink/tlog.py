"""MAVLink telemetry logs (``.tlog``): fast streaming reader.

A tlog is what a ground station records: each MAVLink v1/v2 frame prefixed by its
8-byte big-endian receive time (µs since the Unix epoch). The file is read in chunks
of :data:`CHUNK` bytes (a partial frame carries over to the next chunk, so memory is
bounded by the decoded output); a numba kernel finds the frames and checks their CRC
(:mod:`etsid.ingest.mavlink.scan`), and only the messages in
:data:`~etsid.ingest.mavlink.signals.DECODERS` (plus those named by ``--map``) are
gathered, chunk by chunk, into one array per message (:mod:`etsid.ingest.mavlink.store`)
and decoded with numpy dtypes built from pymavlink's own definitions
(:mod:`etsid.ingest.mavlink.dtypes`). Columns, units and priorities:
:mod:`etsid.ingest.mavlink.signals`; time handling: :mod:`etsid.ingest.mavlink.clock`.

System choice: ``options.sysid``, else the system with the most ATTITUDE messages
(ground stations, sysid 255, never count); within it the component with the most
ATTITUDE messages. Frames with a bad CRC, unknown message ids and skipped bytes are
counted in ``dropped``; a file cut mid-frame gives its valid part and a warning.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from etsid.errors import IngestError
from etsid.files import open_binary
from etsid.ingest.base import Channel, Issue, Override, RawLog, ReadOptions, Signal
from etsid.ingest.damage import gap_note
from etsid.ingest.kernel_choice import use_kernels
from etsid.ingest.mavlink.clock import BOOT, NONE, WRAP32_US, Clock, autopilot_clock
from etsid.ingest.mavlink.dtypes import (
    crc_extra_table,
    message_class,
    message_dtype,
    message_ids,
)
from etsid.ingest.mavlink.scan import (
    UNKNOWN,
    ScanResult,
    frame_key_stats,
    scan_arrays,
    scan_frames,
)
from etsid.ingest.mavlink.signals import CLOCK_FIELDS, DECODERS
from etsid.ingest.mavlink.store import FrameStore
from etsid.ingest.vehicle import (
    ardupilot_version,
    autopilot_name,
    decode_text,
    first_banner,
    mav_type_name,
)
from etsid.progress import progress

CHUNK = 8 << 20
"""Bytes read per step."""
GCS_SYSID = 255
ATTITUDE_ID = 30


@dataclass
class _Stats:
    """Per (sysid, compid, msgid) counts and ground-station time span, plus damage counts."""

    count: dict[int, int] = field(default_factory=dict)
    first: dict[int, float] = field(default_factory=dict)
    last: dict[int, float] = field(default_factory=dict)
    unknown: dict[int, int] = field(default_factory=dict)
    skipped: int = 0
    bad_crc: int = 0
    truncated: int = 0
    gaps_us: list[tuple[int, int]] = field(default_factory=list)  # around skipped bytes
    first_us: int | None = None
    last_us: int | None = None

    def locate(self, res: ScanResult) -> None:
        """Time spans around skipped bytes: a frame's payload starts more than a record
        header (8-byte stamp + frame header, ≤ 31 bytes) after the previous frame's end."""
        if not res.offset.size:
            return
        off = res.offset.astype(np.int64)
        end = off + res.length.astype(np.int64) + 2  # CRC after the payload
        step = off[1:] - end[:-1]
        stamps = res.stamp_us.astype(np.int64)
        for i in np.flatnonzero(step > 31).tolist():
            self.gaps_us.append((int(stamps[i]), int(stamps[i + 1])))
        if self.last_us is not None and off[0] > 31:
            self.gaps_us.append((self.last_us, int(stamps[0])))
        self.first_us = int(stamps[0]) if self.first_us is None else self.first_us
        self.last_us = int(stamps[-1])

    def add(self, res: ScanResult, fast: bool) -> None:
        if not res.msgid.size:
            return
        for kk, c, a, b in zip(*frame_key_stats(res.sysid, res.compid, res.msgid,
                                                res.stamp_us, fast), strict=True):
            self.count[kk] = self.count.get(kk, 0) + c
            self.first[kk] = min(self.first.get(kk, a), a)
            self.last[kk] = max(self.last.get(kk, b), b)


def _wanted_ids(overrides: list[Override], path: Path) -> dict[int, str]:
    ids = message_ids()
    wanted = {ids[name]: name for name in DECODERS}
    for o in overrides:
        if o.topic not in ids:
            raise IngestError(f"{path}: --map {o.text}: {o.topic!r} is not a MAVLink message "
                              "name (e.g. ATTITUDE, RC_CHANNELS)")
        wanted[ids[o.topic]] = o.topic
    return wanted


def _scan_file(path: Path, wanted: dict[int, str], show: bool
               ) -> tuple[_Stats, dict[int, dict[str, np.ndarray]], int]:
    """Read the file chunk by chunk; gather the wanted messages of every system (ids in
    the order of ``wanted``, those with frames only)."""
    stats = _Stats()
    ids = list(wanted)
    store = FrameStore(ids, [message_dtype(mid).itemsize for mid in ids])
    table = crc_extra_table()
    size = path.stat().st_size
    carry = np.empty(0, np.uint8)
    data = np.empty(0, np.uint8)  # one buffer for every chunk: the carry, then the read
    found = scan_arrays(CHUNK)  # the frames of a chunk, reused likewise
    base = done = 0
    with open_binary(path, "log", IngestError) as handle, \
            progress(size, f"reading {path.name}", show) as bar:
        while True:
            if data.size < carry.size + CHUNK:
                data = np.empty(carry.size + CHUNK, np.uint8)
            data[:carry.size] = carry
            got = handle.readinto(memoryview(data)[carry.size:carry.size + CHUNK]) or 0
            final = handle.tell() >= size or not got
            buf = data[:carry.size + got]  # (nothing kept refers to it: payloads are copied)
            res = scan_frames(buf, table, final, found)
            fast = use_kernels(buf.size)
            stats.skipped += res.skipped
            stats.bad_crc += res.bad_crc
            if res.skipped:
                stats.locate(res)
            elif res.offset.size:
                stats.first_us = stats.first_us if stats.first_us is not None else \
                    int(res.stamp_us[0])
                stats.last_us = int(res.stamp_us[-1])
            stats.add(res, fast)
            unknown = res.status == UNKNOWN
            if unknown.any():
                for mid, c in zip(*np.unique(res.msgid[unknown], return_counts=True),
                                  strict=True):
                    stats.unknown[int(mid)] = stats.unknown.get(int(mid), 0) + int(c)
            done += got
            store.add(buf, res, base, 1.0 if final else min(done / max(size, 1), 1.0), fast)
            base += res.offset.size
            bar.update(got)
            carry = buf[res.consumed:].copy()
            if final:
                stats.truncated = int(carry.size)
                break
    return stats, store.parts({mid: message_dtype(mid) for mid in ids}), base


def _choose_system(stats: _Stats, options: ReadOptions, path: Path) -> tuple[int, int, dict]:
    frames: dict[int, int] = {}
    att: dict[tuple[int, int], int] = {}
    for key, c in stats.count.items():
        sysid, compid, msgid = key >> 32, (key >> 24) & 0xFF, key & 0xFFFFFF
        frames[sysid] = frames.get(sysid, 0) + c
        if msgid == ATTITUDE_ID:
            att[(sysid, compid)] = att.get((sysid, compid), 0) + c
    vehicles = sorted(s for s in frames if s != GCS_SYSID)
    if options.sysid is not None:
        if options.sysid not in frames:
            raise IngestError(f"{path}: --sysid {options.sysid} not in the log; system ids "
                              f"found: {', '.join(map(str, sorted(frames)))}")
        sysid = options.sysid
    elif not vehicles:
        raise IngestError(f"{path}: only ground-station packets (sysid 255), no vehicle")
    else:
        per_sys = {s: sum(c for (ss, _), c in att.items() if ss == s) for s in vehicles}
        sysid = max(vehicles, key=lambda s: (per_sys[s], frames[s], -s))
    comps = {(k >> 24) & 0xFF: 0 for k in stats.count if k >> 32 == sysid}
    for (s, c), n in att.items():
        if s == sysid:
            comps[c] = n
    if not any(comps.values()):
        for k, n in stats.count.items():
            if k >> 32 == sysid:
                comps[(k >> 24) & 0xFF] += n
    compid = max(comps, key=lambda c: (comps[c], -c))
    return sysid, compid, frames


def _logged_places(indexes: list[np.ndarray], nframes: int) -> list[np.ndarray]:
    """Where each message's frames go in logged order: the rank of each frame number among
    all of ``indexes`` (distinct numbers in ``[0, nframes)``). When every frame of the log
    is decoded, the rank is the number itself."""
    if sum(i.size for i in indexes) == nframes:
        return indexes
    present = np.zeros(nframes, np.bool_)
    for i in indexes:
        present[i] = True
    rank = np.cumsum(present, dtype=np.int64) - 1
    return [rank[i] for i in indexes]


_KIND_CODES = {"ms": BOOT, "us32": WRAP32_US, "us": BOOT}
_SCALES = {"ms": 1e-3, "us32": 1e-6, "us": 1e-6}
UNIX_US = 10**15
"""A ``time_usec`` above this (µs, 31 years) is Unix time, not time since boot."""


def _logged_clocks(msgs: dict[int, dict[str, np.ndarray]], names: dict[int, str],
                   places: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ground-station stamps (s), own clocks (s) and clock kinds of every decoded frame, in
    logged order (see :func:`etsid.ingest.mavlink.clock.autopilot_clock`). Once numba is
    loaded, one compiled pass per message writes its frames in place (numpy's fancy-index
    writes are slow); otherwise numpy writes them."""
    n = sum(p.size for p in places)
    gcs, value, kind = np.empty(n), np.empty(n), np.empty(n, np.int8)
    fast = "numba" in sys.modules
    for (mid, m), at in zip(msgs.items(), places, strict=True):
        fld, how = CLOCK_FIELDS.get(names[mid], ("", ""))
        field = m["rec"][fld] if how else m["stamp"]
        code, scale = _KIND_CODES.get(how, NONE), _SCALES.get(how, 0.0)
        unix_from = UNIX_US if how == "us" else 0
        if fast:
            from etsid.ingest.mavlink.clock_kernel import place_clock

            place_clock(at, m["stamp"], field, scale, code, field.dtype.type(unix_from), gcs,
                        value, kind)
            continue
        gcs[at] = m["stamp"] * 1e-6
        value[at] = field.astype(np.float64) * scale if how else 0.0
        kind[at] = np.where(field > unix_from, NONE, code) if unix_from else code
    return gcs, value, kind


def _override_signal(o: Override, rec: np.ndarray, t: np.ndarray, path: Path) -> Signal:
    match = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", o.field or "")
    names = rec.dtype.names or ()
    if not match or match.group(1) not in names:
        raise IngestError(f"{path}: --map {o.text}: {o.topic} has no field {o.field!r} "
                          f"(fields: {', '.join(names)})")
    values = rec[match.group(1)]
    if match.group(2) is not None:
        values = values[:, int(match.group(2))]
    return Signal(o.column, t, values.astype(np.float64), f"{o.topic}.{o.field}", -1)


def read(path: Path, options: ReadOptions) -> RawLog:
    """Read a tlog into a :class:`RawLog` (see the module docstring)."""
    wanted = _wanted_ids(options.field_requests(), path)
    meta = {mid: name for mid, name in _meta_ids().items() if mid not in wanted}
    try:
        stats, blocks, nframes = _scan_file(path, {**wanted, **meta}, options.progress)
    except OSError as err:
        raise IngestError(f"{path}: cannot read ({err.strerror or err})") from err
    if not stats.count:
        raise IngestError(f"{path}: no valid MAVLink packets found "
                          f"({stats.skipped + stats.truncated} bytes scanned)")
    sysid, compid, frames = _choose_system(stats, options, path)
    meta_blocks = {mid: blocks.pop(mid) for mid in meta if mid in blocks}
    raw = RawLog(path=path, format="tlog")
    # decoded messages of the chosen component, merged in logged order for the clock
    msgs: dict[int, dict[str, np.ndarray]] = {}
    for mid, cat in blocks.items():
        mine = (cat["sysid"] == sysid) & (cat["compid"] == compid)
        if mine.all():  # one system: no copy (the values are the same)
            msgs[mid] = cat
        elif mine.any():
            msgs[mid] = {k: v[mine] for k, v in cat.items()}
    names = {mid: wanted[mid] for mid in msgs}
    # every decoded frame at its place in logged order (its rank: no sort, no joins)
    places = _logged_places([m["index"] for m in msgs.values()], nframes)
    clock = autopilot_clock(*_logged_clocks(msgs, names, places))
    raw.start_time = clock.start_time
    _clock_issues(raw, clock)
    overrides = options.field_requests()
    times: dict[int, tuple[float, float]] = {}
    for (mid, m), at in zip(msgs.items(), places, strict=True):
        # into a numpy array: numba's arrays carry float64 as another dtype object, and
        # np.asarray(t, dtype=float) then makes a new view per signal, which defeats the
        # work kept once per time array downstream (id(t): native period, gaps, strays)
        t = np.take(clock.t, at, out=np.empty(at.size))
        rec = m["rec"]
        late = int(np.count_nonzero(t < np.maximum.accumulate(t)))
        if late:
            srt = np.argsort(t, kind="stable")
            t, rec = t[srt], rec[srt]
            raw.repaired.append(Issue("packets that arrived late over the link, re-sorted by "
                                      "autopilot clock", late, names[mid]))
        times[mid] = (float(t[0]), float(t[-1]))
        if names[mid] in DECODERS:
            raw.signals.extend(DECODERS[names[mid]](rec, t, options, raw.repaired))
        for o in overrides:
            if o.topic == names[mid]:
                raw.signals.append(_override_signal(o, rec, t, path))
    raw.signals = [s for s in raw.signals if np.count_nonzero(np.isfinite(s.values)) >= 2]
    _catalogue(raw, stats, sysid, compid, times, clock.start_time)
    _damage(raw, stats, path)
    raw.extra.update({
        "sysid": sysid,
        "compid": compid,
        "sysids": sorted(frames),
        "frames": nframes,
        **_facts(msgs.get(message_ids()["HEARTBEAT"]), meta_blocks, sysid),
    })
    if sorted(s for s in frames if s != sysid):
        others = ", ".join(f"{s} ({frames[s]} frames)" for s in sorted(frames) if s != sysid)
        raw.warnings.append(f"used system {sysid}; ignored other system ids: {others}")
    if not clock.own_clock:
        raw.warnings.append("no message with an autopilot clock: using ground-station time")
    return raw


META_MESSAGES = ("STATUSTEXT", "AUTOPILOT_VERSION")
"""Messages decoded only for what they say about the aircraft (:func:`_facts`)."""


def _meta_ids() -> dict[int, str]:
    ids = message_ids()
    return {ids[name]: name for name in META_MESSAGES}


def _of_system(part: dict[str, np.ndarray] | None, sysid: int) -> np.ndarray | None:
    if part is None:
        return None
    rec = part["rec"][part["sysid"] == sysid]
    return rec if rec.size else None


def _facts(heartbeat: dict[str, np.ndarray] | None,
           meta: dict[int, dict[str, np.ndarray]], sysid: int) -> dict[str, str]:
    """Vehicle and autopilot from the chosen component's HEARTBEATs (the most frequent
    type), firmware from its system's banner STATUSTEXT, else AUTOPILOT_VERSION."""
    facts: dict[str, str] = {}
    ids = message_ids()
    texts = _of_system(meta.get(ids["STATUSTEXT"]), sysid)
    banner, _ = first_banner([decode_text(t) for t in texts["text"]] if texts is not None
                             else [])
    if heartbeat is not None and heartbeat["rec"].size:
        rec = heartbeat["rec"]
        pairs, counts = np.unique(np.stack([rec["type"].astype(np.int64),
                                            rec["autopilot"].astype(np.int64)]),
                                  axis=1, return_counts=True)
        kind, pilot = (int(v) for v in pairs[:, int(np.argmax(counts))])
        facts.update({k: v for k, v in (("vehicle", mav_type_name(kind)),
                                         ("autopilot", autopilot_name(pilot))) if v})
    for key, value in banner.items():
        facts.setdefault(key, value)
    version = _of_system(meta.get(ids["AUTOPILOT_VERSION"]), sysid)
    if "firmware" not in facts and version is not None:
        word = ardupilot_version(int(version["flight_sw_version"][-1]))
        if word:
            facts["firmware"] = word
    return dict(sorted(facts.items()))


def _clock_issues(raw: RawLog, clock: Clock) -> None:
    if clock.reboots:
        raw.repaired.append(Issue(
            f"autopilot clock stepped back {clock.reboots} time(s) (reboot): later frames "
            "placed by ground-station time", clock.rebooted_frames, "time_boot_ms"))
    if clock.ms_wraps:
        raw.repaired.append(Issue("uint32 time_boot_ms wrap (49.7 days) unwrapped",
                                  clock.ms_wraps, "time_boot_ms"))
    if clock.us_wraps:
        raw.repaired.append(Issue("uint32 time_usec wrap (71.6 min) unwrapped",
                                  clock.us_wraps, "SERVO_OUTPUT_RAW.time_usec"))


def _catalogue(raw: RawLog, stats: _Stats, sysid: int, compid: int,
               times: dict[int, tuple[float, float]], start: float | None) -> None:
    columns: dict[str, list[str]] = {}
    for sig in raw.signals:
        cols = columns.setdefault(sig.topic, [])
        if sig.column not in cols:
            cols.append(sig.column)
    for key in sorted(stats.count, key=lambda k: k & 0xFFFFFF):
        if key >> 32 != sysid or (key >> 24) & 0xFF != compid:
            continue
        mid = key & 0xFFFFFF
        name = message_class(mid).msgname if mid < crc_extra_table().size and \
            crc_extra_table()[mid] >= 0 else f"UNKNOWN_{mid}"
        if mid in times:
            first, last = times[mid]
        else:
            t0 = start or 0.0
            first, last = stats.first[key] * 1e-6 - t0, stats.last[key] * 1e-6 - t0
        raw.channels.append(Channel(name, "mavlink", stats.count[key], first, last,
                                    columns.get(name, []),
                                    "" if mid in times else "ground-station time"))


def _damage(raw: RawLog, stats: _Stats, path: Path) -> None:
    if stats.bad_crc:
        raw.dropped.append(Issue("frame with a bad CRC", stats.bad_crc, ""))
    for mid, n in sorted(stats.unknown.items()):
        raw.dropped.append(Issue(f"unknown MAVLink message id {mid}", n, ""))
    if stats.skipped:
        raw.dropped.append(Issue("bytes between frames that are no valid tlog record",
                                 stats.skipped, ""))
        t0 = stats.first_us or 0
        spans = [((a - t0) * 1e-6, (b - t0) * 1e-6) for a, b in stats.gaps_us]
        last = None if stats.last_us is None else (stats.last_us - t0) * 1e-6
        bad = f", {stats.bad_crc} of them frames with a bad CRC" if stats.bad_crc else ""
        what = (f"skipped {stats.skipped} bytes that are no valid tlog record{bad} "
                "(times on the ground-station clock)")
        raw.warnings.append(gap_note(path.name, what, spans, 0.0, last))
    if stats.truncated:
        raw.dropped.append(Issue("bytes of a truncated last frame", stats.truncated, ""))
        raw.warnings.append(f"{path.name}: file is truncated: skipped the last "
                            f"{stats.truncated} bytes (an incomplete frame)")
