"""Read flight logs of every supported format into one FlightTable.

>>> from etsid.ingest import FORMATS
>>> sorted(FORMATS)
['bin', 'mcap', 'ros1', 'ros2', 'tlog', 'ulog']
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from etsid.errors import EtsidError, IngestError, TableError
from etsid.ingest.align import build_table, native_rate
from etsid.ingest.base import Channel, Override, RawLog, ReadOptions, Signal, printable
from etsid.ingest.damage import decoder_errors, describe
from etsid.ingest.detect import FORMATS, detect_format, open_reader
from etsid.ingest.mapping import choose_signals
from etsid.table import COLUMNS, is_table_path, load_table

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = [
    "FORMATS",
    "Override",
    "ReadOptions",
    "detect_format",
    "inspect_log",
    "read_log",
    "read_raw",
    "read_table",
]


def read_raw(path: str | Path, options: ReadOptions | None = None) -> RawLog:
    """Run the right reader on ``path`` and return its :class:`RawLog` (no alignment)."""
    path = Path(path)
    fmt = detect_format(path)
    reader = open_reader(fmt)
    try:
        return _printable_notes(reader(path, options or ReadOptions()))
    except IngestError as err:
        shown = _shown(str(err))
        if shown == str(err):
            raise
        raise IngestError(shown) from err
    except EtsidError:
        raise
    except decoder_errors() as err:  # the one error path for damaged bytes (damage.py)
        raise IngestError(f"{path}: damaged {fmt} file, nothing could be read "
                          f"({describe(err)})") from err


MAX_ERROR_CHARS = 600
"""Length of an error message from a reader; the rest is cut (names in it come from the
log and may be long)."""


def _shown(text: str) -> str:
    """``text`` with control characters shown (:func:`printable`) and cut to one line of
    :data:`MAX_ERROR_CHARS`."""
    text = printable(text)
    return text if len(text) <= MAX_ERROR_CHARS else text[:MAX_ERROR_CHARS] + " …"


def _printable_notes(raw: RawLog) -> RawLog:
    """Notes and issue names with control characters shown, not sent (names in them come
    from the log: a terminal escape there would reach the user's terminal and reports)."""
    raw.warnings = [printable(w) for w in raw.warnings]
    for issue in (*raw.dropped, *raw.repaired):
        issue.reason, issue.signal = printable(issue.reason), printable(issue.signal)
    for channel in raw.channels:
        channel.note = printable(channel.note)
    return raw


def read_log(
    path: str | Path,
    options: ReadOptions | None = None,
    rate_hz: float | None = None,
    start: float | None = None,
    end: float | None = None,
) -> pd.DataFrame:
    """Read a flight log, or a saved table (``.parquet``/``.csv``), into a FlightTable.

    The one entry point for every command that takes a log (see etsid/table.py for the
    contract). A saved table is already on its grid: ``--map``/``--mapping``/``--sysid``
    and ``rate_hz`` do not apply to it and are refused rather than ignored;
    ``start``/``end`` cut it (:func:`read_table`).

    Raises
    ------
    IngestError
        One-line message naming the file and what is wrong.
    """
    if is_table_path(path):
        return read_table(path, options, rate_hz=rate_hz, start=start, end=end)
    options = options or ReadOptions()
    raw = read_raw(path, options)
    return table_from_raw(raw, options.overrides, rate_hz=rate_hz, start=start, end=end)


def table_from_raw(
    raw: RawLog,
    overrides: list[Override],
    rate_hz: float | None = None,
    start: float | None = None,
    end: float | None = None,
    preset: dict[str, Signal] | None = None,
) -> pd.DataFrame:
    """Choose one signal per column of ``raw`` (honouring ``overrides``) and align them.

    The second half of :func:`read_log`, for callers that choose some columns' signals
    themselves from the reader's candidates and pass them as ``preset`` (``etsid identify
    --inputs``; see :func:`etsid.ingest.mapping.choose_signals`).
    """
    if all(s.column in ("landed", "ground_contact") for s in raw.signals):  # no flight data
        kinds = ", ".join(sorted({_shown(f"{c.name} ({c.type})")[:120]
                                  for c in raw.channels})[:12])
        raise IngestError(
            f"{raw.path}: no usable flight data; found {kinds or 'no messages'}"
        )
    chosen, notes = choose_signals(raw.signals, overrides, raw.path, preset)
    raw.warnings.extend(notes)
    table = build_table(raw, chosen, rate_hz=rate_hz, start=start, end=end)
    note = missing_core_note(raw, list(table.columns))
    if note:
        table.attrs["warnings"].append(note)
    attrs = table.attrs  # sources named after topics: shown, never sent raw (see printable)
    attrs["warnings"] = [printable(w) for w in attrs.get("warnings", [])]
    attrs["mapping"] = {c: printable(v) for c, v in (attrs.get("mapping") or {}).items()}
    for sig in (attrs.get("signals") or {}).values():
        sig["source"] = printable(sig["source"])
    if isinstance(attrs.get("reference"), str):
        attrs["reference"] = printable(attrs["reference"])
    return table


CORE_COLUMNS = ("p", "q", "r", "roll", "pitch", "yaw")
"""Columns every flight log is expected to fill; a table without them gets a note."""


def missing_core_note(raw: RawLog, columns: list[str]) -> str | None:
    """A note naming the core columns the table lacks and the channels that might have
    filled them (an unrecognised or undecodable type, e.g. a damaged type name)."""
    missing = [c for c in CORE_COLUMNS if c not in columns]
    if not missing:
        return None
    suspects = [f"{c.name} ({c.type}: {c.note})" if c.note else f"{c.name} ({c.type})"
                for c in raw.channels if not c.columns and c.count and (
                    c.note or any(k in c.name.lower() for k in ("imu", "att", "gyro")))]
    hint = f"; not understood: {', '.join(suspects[:3])}" if suspects else ""
    return (f"{raw.path}: no {' '.join(missing)} in the table: nothing in the log fills "
            f"{'it' if len(missing) == 1 else 'them'}{hint}")


def read_table(path: str | Path, options: ReadOptions | None = None,
               rate_hz: float | None = None, start: float | None = None,
               end: float | None = None) -> pd.DataFrame:
    """A saved table as a FlightTable, cut to ``start``..``end`` (s); see :func:`read_log`."""
    options = options or ReadOptions()
    unused = [name for name, given in (
        ("--map/--mapping", bool(options.overrides) or options.rc_map != ReadOptions().rc_map),
        ("--sysid", options.sysid is not None),
        ("--rate", rate_hz is not None),
    ) if given]
    if unused:
        raise IngestError(f"{path}: a saved table is already on its grid; "
                          f"{', '.join(unused)} only apply to flight logs")
    try:
        table = load_table(path)
    except TableError as err:
        raise IngestError(str(err)) from err
    if start is None and end is None:
        return table
    for name, value in (("--start", start), ("--end", end)):
        if value is not None and not (np.isfinite(value) and value >= 0):
            raise IngestError(f"{path}: {name} must be a time ≥ 0 s, got {value:g}")
    t = table.index.to_numpy(dtype=float)
    lo = (t[0] if t.size else 0.0) + (start or 0.0)
    hi = np.inf if end is None else (t[0] if t.size else 0.0) + end
    cut = table[(t >= lo) & (t <= hi)].copy()
    if len(cut) < 2:
        raise IngestError(f"{path}: the window --start/--end selects fewer than two rows")
    import pandas as pd

    cut.index = pd.Index(cut.index.to_numpy(dtype=float) - cut.index[0], name="t")
    cut.attrs = dict(table.attrs)
    return cut


def inspect_table(path: str | Path) -> dict[str, Any]:
    """``etsid inspect`` summary of a saved table: one row per column, with provenance notes."""
    try:
        table = load_table(path)
    except TableError as err:
        raise IngestError(str(err)) from err
    attrs = table.attrs
    t = table.index.to_numpy(dtype=float)
    duration = float(t[-1] - t[0]) if t.size else None
    channels = []
    for column in table.columns:
        count = int(table[column].notna().sum())
        rate = (count - 1) / duration if duration and count > 1 else 0.0
        channels.append({"name": column, "type": str(table[column].dtype), "count": count,
                         "rate_hz": round(rate, 3),
                         "columns": [column] if column in COLUMNS else [], "note": ""})
    notes = list(attrs.get("warnings") or [])
    if not t.size:
        notes.append("the table has no rows")
    return {
        "path": str(path),
        "format": f"table ({attrs.get('format', 'table')})",
        "start_time": attrs.get("start_time"),
        "duration_s": duration,
        "channels": channels,
        "mapping": dict(attrs.get("mapping") or {}),
        "dropped": list(attrs.get("dropped") or []),
        "repaired": list(attrs.get("repaired") or []),
        "warnings": notes,
        "extra": {"rows": len(table), "source": attrs.get("source", str(path))},
    }


BURST_SPAN = 0.1
"""A channel whose messages span less than this fraction of the log came in a burst."""


def robust_rate(channel: Channel, signals: list[Signal], log_first: float | None,
                log_last: float | None) -> tuple[float, str]:
    """Rate of ``channel`` for ``inspect``, Hz, and a note on how it was told.

    From the timestamps of a signal of the channel when there is one: the reciprocal of
    the typical spacing (:func:`etsid.ingest.align.native_rate`, robust to gaps and bursts).
    Otherwise count / span; a channel whose messages all came within a small part of the
    log (a burst of parameters or mission items at start-up) is given its mean rate over
    the whole log instead, and the note says so.
    """
    for sig in signals:
        if sig.topic == channel.name and sig.t.size > 2:
            t = np.sort(np.asarray(sig.t, dtype=float)[np.isfinite(sig.t)])
            t = t[np.concatenate(([True], np.diff(t) > 0))] if t.size else t
            if t.size > 2:
                rate = native_rate(t)
                if np.isfinite(rate):
                    return float(rate), ""
    rate = channel.rate_hz
    if (log_first is None or log_last is None or channel.t_first is None
            or channel.t_last is None or channel.count < 2):
        return rate, ""
    log_span = log_last - log_first
    span = channel.t_last - channel.t_first
    if log_span > 0 and span < BURST_SPAN * log_span:
        return channel.count / log_span, "burst: mean rate over the log"
    return rate, ""


def inspect_log(path: str | Path, options: ReadOptions | None = None) -> dict[str, Any]:
    """Summary of a log for ``etsid inspect``: format, duration, channels, mapping, issues."""
    if is_table_path(path):
        read_table(path, options)  # refuses --map/--sysid, which do not apply to a table
        return inspect_table(path)
    raw = read_raw(path, options)
    times = [c for c in raw.channels if c.t_first is not None and c.t_last is not None]
    t_first = min((c.t_first for c in times), default=None)  # type: ignore[type-var]
    t_last = max((c.t_last for c in times), default=None)  # type: ignore[type-var]
    chosen: dict[str, Any] = {}
    notes: list[str] = []
    if raw.signals:
        picked, notes = choose_signals(raw.signals, (options or ReadOptions()).overrides,
                                       raw.path)
        chosen = {c: s.source for c, s in picked.items()}
    else:
        notes.append("no topic or message fills a FlightTable column: nothing to ingest "
                     "(use --map COLUMN=TOPIC.FIELD to map fields by hand)")
    return {
        "path": str(raw.path),
        "format": raw.format,
        "start_time": raw.start_time,
        "duration_s": None if t_first is None else float(t_last - t_first),  # type: ignore[operator]
        "channels": [
            {"name": c.name, "type": c.type, "count": c.count,
             "rate_hz": round(rate, 3), "columns": c.columns,
             "note": "; ".join(n for n in (c.note, why) if n)}
            for c in raw.channels
            for rate, why in [robust_rate(c, raw.signals, t_first, t_last)]
        ],
        "mapping": chosen,
        "dropped": [vars(i) for i in raw.dropped],
        "repaired": [vars(i) for i in raw.repaired],
        "warnings": raw.warnings + notes,
        "extra": {k: v for k, v in raw.extra.items()},
    }
