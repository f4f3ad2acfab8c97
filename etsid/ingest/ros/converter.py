"""Collect decoded ROS messages topic by topic while streaming, then build the RawLog.

A :class:`Converter` receives each decoded message (or, from the vectorised path of
:mod:`etsid.ingest.ros.fast`, a batch already turned into rows) with its record (log)
time, keeps only the numbers its topic's :class:`~etsid.ingest.ros.messages.Spec` needs
(compact ``array('d')`` buffers, memory bounded by the output) and at the end hands
them to the spec's finish function, which gives SI, FRD/NED signals.

Time: ``header.stamp`` when valid (non-zero and within a day of the record time), else
the record time (counted in ``repaired``); px4_msgs ``timestamp`` (µs) and MAVLink
``time_boot_ms``/``time_usec`` are on the autopilot boot clock, shifted to the record
clock by one offset per log (the smallest record-minus-boot delay).
"""

from __future__ import annotations

from array import array
from typing import Any

import numpy as np

from etsid.ingest.base import Channel, Issue, Override, RawLog, ReadOptions, Signal, get_field
from etsid.ingest.ros.messages import Batch, Spec, spec_for

PLAUSIBLE_NS = 86_400 * 1_000_000_000
"""A header stamp further than this from the record time is not trusted."""
MAX_TOPIC_NOTES = 10
"""Topics with undecodable messages named one by one in the warnings; the rest are
counted in one line (each keeps its channel note)."""


class TopicData:
    """Numbers collected from one topic while streaming."""

    def __init__(self, topic: str, msgtype: str, spec: Spec | None, note: str,
                 requests: list[Override]) -> None:
        self.topic, self.msgtype, self.spec, self.note = topic, msgtype, spec, note
        self.requests = requests
        self.count = 0
        self.first_ns: int | None = None
        self.last_ns: int | None = None
        self.t = array("d")
        self.rows = array("d")
        self.width = 0
        self.bad_stamp = 0
        self.failed = 0
        self.error = ""
        self.zero_stamp = 0
        self.undecodable = 0
        """Messages whose bytes did not decode (skipped one by one, never the topic)."""
        self.bad_ns: tuple[int, int] | None = None
        self.bad_why = ""
        self.req_t: list[array[float]] = [array("d") for _ in requests]
        self.req_v: list[array[float]] = [array("d") for _ in requests]

    @property
    def decode(self) -> bool:
        """Whether messages of this topic need decoding at all."""
        return self.spec is not None or bool(self.requests)


class Converter:
    """Collect decoded messages of any number of topics, then build a :class:`RawLog`."""

    def __init__(self, options: ReadOptions) -> None:
        self.options = options
        self.topics: dict[str, TopicData] = {}
        self.base_ns: int | None = None
        self.boot_offset_ns: int | None = None

    def topic(self, topic: str, msgtype: str) -> TopicData:
        """The collector for ``topic`` (created on first use)."""
        data = self.topics.get(topic)
        if data is None:
            spec, note = spec_for(msgtype, topic)
            requests = [o for o in self.options.field_requests() if o.topic == topic]
            data = self.topics[topic] = TopicData(topic, msgtype, spec, note, requests)
        return data

    def count(self, data: TopicData, log_ns: int) -> None:
        """Count a message that is not decoded."""
        if self.base_ns is None:
            self.base_ns = log_ns
        data.count += 1
        if data.first_ns is None:
            data.first_ns = log_ns
        data.last_ns = log_ns

    def undecodable(self, data: TopicData, log_ns: int, err: BaseException) -> None:
        """Count a message whose bytes did not decode: it alone is skipped."""
        self.count(data, log_ns)
        data.undecodable += 1
        if data.bad_ns is None:
            data.bad_ns = (log_ns, log_ns)
            data.bad_why = _one_line(err)
        else:
            data.bad_ns = (min(data.bad_ns[0], log_ns), max(data.bad_ns[1], log_ns))

    def undecodable_many(self, data: TopicData, log_ns: np.ndarray, err: BaseException
                         ) -> None:
        """:meth:`undecodable` for messages (record times ``log_ns``, in order) that all
        failed alike (identical bytes: decoded once)."""
        if not len(log_ns):
            return
        self.count_many(data, log_ns)
        data.undecodable += len(log_ns)
        lo, hi = int(log_ns.min()), int(log_ns.max())
        if data.bad_ns is None:
            data.bad_ns, data.bad_why = (lo, hi), _one_line(err)
        else:
            data.bad_ns = (min(data.bad_ns[0], lo), max(data.bad_ns[1], hi))

    def add(self, data: TopicData, msg: Any, log_ns: int) -> None:
        """Take the numbers needed from one decoded message received at ``log_ns``."""
        self.count(data, log_ns)
        spec = data.spec
        stamp = log_ns
        if spec is not None and spec.clock is not None:
            try:
                stamp = spec.clock(msg)
            except (AttributeError, TypeError, ValueError):
                stamp = 0
            if spec.boot:
                if stamp <= 0:
                    data.zero_stamp += 1
                    return
                delay = log_ns - stamp
                if self.boot_offset_ns is None or delay < self.boot_offset_ns:
                    self.boot_offset_ns = delay
            elif stamp <= 0 or abs(stamp - log_ns) > PLAUSIBLE_NS:
                data.bad_stamp += 1
                stamp = log_ns
        t = stamp * 1e-9 if spec is not None and spec.boot else (stamp - self.base_ns) * 1e-9
        if spec is not None:
            try:
                row = spec.row(msg)
            except (AttributeError, TypeError, ValueError, IndexError, KeyError) as err:
                data.failed += 1
                data.error = data.error or f"{type(err).__name__}: {err}"
            else:
                if not data.width:
                    data.width = len(row)
                data.rows.extend(row)
                data.t.append(t)
        for i, req in enumerate(data.requests):
            try:
                value = get_field(msg, req.field or "")
            except (AttributeError, TypeError, ValueError, IndexError, KeyError):
                continue
            data.req_t[i].append(t)
            data.req_v[i].append(value)

    def count_many(self, data: TopicData, log_ns: np.ndarray) -> None:
        """Count messages that are not decoded (record times ``log_ns``, in order)."""
        if len(log_ns):
            if self.base_ns is None:
                self.base_ns = int(log_ns[0])
            data.count += len(log_ns)
            if data.first_ns is None:
                data.first_ns = int(log_ns[0])
            data.last_ns = int(log_ns[-1])

    def add_rows(self, data: TopicData, stamps: np.ndarray, log_ns: np.ndarray,
                 rows: np.ndarray) -> None:
        """Vectorised :meth:`add` of a batch already turned into rows.

        Parameters
        ----------
        data : TopicData
            The topic (its spec gives the clock kind); no field requests.
        stamps : numpy.ndarray
            int64 message clock per message (``spec.clock``), ns.
        log_ns : numpy.ndarray
            int64 record times, ns.
        rows : numpy.ndarray
            float64 (messages, width): what ``spec.row`` gives per message.
        """
        spec = data.spec
        assert spec is not None and not data.requests
        self.count_many(data, log_ns)
        stamps = np.array(stamps, dtype=np.int64)
        if spec.boot:
            ok = stamps > 0
            data.zero_stamp += int((~ok).sum())
            stamps, log_ns, rows = stamps[ok], log_ns[ok], rows[ok]
            if len(stamps):
                delay = int((log_ns - stamps).min())
                if self.boot_offset_ns is None or delay < self.boot_offset_ns:
                    self.boot_offset_ns = delay
            t = stamps.astype(np.float64) * 1e-9
        else:
            bad = (stamps <= 0) | (np.abs(stamps - log_ns) > PLAUSIBLE_NS)
            data.bad_stamp += int(bad.sum())
            stamps[bad] = log_ns[bad]
            t = (stamps - np.int64(self.base_ns)).astype(np.float64) * 1e-9
        if not len(t):
            return
        if not data.width:
            data.width = rows.shape[1]
        data.rows.frombytes(np.ascontiguousarray(rows, dtype=np.float64).tobytes())
        data.t.frombytes(np.ascontiguousarray(t).tobytes())

    def finish(self, raw: RawLog) -> None:
        """Fill ``raw`` with channels, signals, start time and issues."""
        base = self.base_ns or 0
        raw.start_time = base * 1e-9 if self.base_ns is not None else None
        shift = ((self.boot_offset_ns or 0) - base) * 1e-9
        noted = 0
        for data in self.topics.values():
            boot = data.spec is not None and data.spec.boot
            signals = self._signals(data, raw, shift if boot else 0.0)
            raw.signals.extend(signals)
            note = data.note
            if data.spec is not None and data.failed:
                note = f"{data.failed} message(s) lacked the expected fields ({data.error})"
                raw.dropped.append(Issue("message lacks expected fields", data.failed,
                                         data.topic))
            if data.undecodable:
                note = self._note_undecodable(data, raw, base, noted < MAX_TOPIC_NOTES)
                noted += 1
            if data.bad_stamp:
                raw.repaired.append(Issue("header.stamp zero or implausible, used record time",
                                          data.bad_stamp, data.topic))
            if data.zero_stamp:
                raw.dropped.append(Issue("timestamp 0 (not set)", data.zero_stamp, data.topic))
            raw.channels.append(Channel(
                name=data.topic, type=data.msgtype, count=data.count,
                t_first=None if data.first_ns is None else (data.first_ns - base) * 1e-9,
                t_last=None if data.last_ns is None else (data.last_ns - base) * 1e-9,
                columns=sorted({s.column for s in signals}, key=_column_order), note=note))

        if noted > MAX_TOPIC_NOTES:
            rest = [d for d in self.topics.values() if d.undecodable][MAX_TOPIC_NOTES:]
            raw.warnings.append(f"… and {len(rest)} more topic(s) with undecodable messages "
                                "(etsid inspect lists them)")
            raw.dropped.append(Issue(f"message undecodable, in {len(rest)} more topics",
                                     sum(d.undecodable for d in rest)))

    @staticmethod
    def _note_undecodable(data: TopicData, raw: RawLog, base: int, warn: bool = True) -> str:
        """Warning (when ``warn``) and dropped count for the messages of ``data`` that did
        not decode; returns the channel note."""
        assert data.bad_ns is not None
        a, b = ((t - base) * 1e-9 for t in data.bad_ns)
        when = f"t = {a:.1f} s" if a == b else f"t = {a:.1f}–{b:.1f} s"
        text = (f"{data.undecodable} of {data.count} message(s) could not be decoded and "
                f"were skipped ({when}; {data.bad_why})")
        if warn:
            raw.warnings.append(f"{data.topic}: {text}")
            raw.dropped.append(Issue("message undecodable", data.undecodable, data.topic))
        return text

    def _signals(self, data: TopicData, raw: RawLog, shift: float) -> list[Signal]:
        out: list[Signal] = []
        if data.spec is not None and data.width and len(data.t):
            t = np.frombuffer(data.t, dtype=float) + shift
            rows = np.frombuffer(data.rows, dtype=float).reshape(len(data.t), data.width)
            batch = Batch(data.topic, t, rows, self.options, raw.dropped, raw.repaired)
            # values from damaged bytes (inf, NaN, huge) turn into NaN/inf here, silently;
            # the plausibility limits drop them and say so
            with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
                out = data.spec.finish(batch)
        for req, tt, vv in zip(data.requests, data.req_t, data.req_v, strict=True):
            if len(tt):
                out.append(Signal(req.column, np.frombuffer(tt, dtype=float) + shift,
                                  np.frombuffer(vv, dtype=float), f"{data.topic}.{req.field}",
                                  priority=-1))
        return out


def _one_line(err: BaseException) -> str:
    """What a decoder raised, in one short line."""
    text = " ".join(str(a) for a in err.args) if err.args else ""
    text = text.strip().splitlines()[0] if text.strip() else ""
    return f"{type(err).__name__}: {text[:120]}" if text else type(err).__name__


def _column_order(name: str) -> int:
    from etsid.table import COLUMNS

    names = list(COLUMNS)
    return names.index(name) if name in names else len(names)
