"""Read flight logs of every supported format into one FlightTable.

>>> from etsid.ingest import FORMATS
>>> sorted(FORMATS)
['bin', 'mcap', 'ros1', 'ros2', 'tlog', 'ulog']
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import IngestError, TableError
from etsid.ingest.align import build_table
from etsid.ingest.base import Override, RawLog, ReadOptions, Signal
from etsid.ingest.detect import FORMATS, detect_format, open_reader
from etsid.ingest.mapping import choose_signals
from etsid.table import COLUMNS, is_table_path, load_table

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
    return reader(path, options or ReadOptions())


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
    if not raw.signals:
        kinds = ", ".join(sorted({f"{c.name} ({c.type})" for c in raw.channels})[:12])
        raise IngestError(
            f"{raw.path}: no usable flight data; found {kinds or 'no messages'}"
        )
    chosen, notes = choose_signals(raw.signals, overrides, raw.path, preset)
    raw.warnings.extend(notes)
    return build_table(raw, chosen, rate_hz=rate_hz, start=start, end=end)


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
             "rate_hz": round(c.rate_hz, 3), "columns": c.columns, "note": c.note}
            for c in raw.channels
        ],
        "mapping": chosen,
        "dropped": [vars(i) for i in raw.dropped],
        "repaired": [vars(i) for i in raw.repaired],
        "warnings": raw.warnings + notes,
        "extra": {k: v for k, v in raw.extra.items()},
    }
