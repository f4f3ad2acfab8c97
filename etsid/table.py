"""The FlightTable contract: column names, units, validation, alignment and storage.

A FlightTable is a :class:`pandas.DataFrame` indexed by ``t`` (float64 seconds from the
first sample, strictly increasing), SI units, body frame FRD and world frame NED.
Columns a log does not have are absent, never zero-filled. ``table.attrs`` carries
provenance (see :data:`ATTRS_KEYS`).

>>> import numpy as np, pandas as pd
>>> df = pd.DataFrame({"p": [0.0, 0.1, 0.2]}, index=pd.Index([0.0, 0.01, 0.02], name="t"))
>>> validate(df).columns.tolist()
['p']
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from etsid import escape, files, schemas
from etsid.errors import TableError

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

Interp = Literal["linear", "hold", "angle"]


@dataclass(frozen=True)
class ColumnSpec:
    """What a FlightTable column means: unit, description and how to resample it."""

    unit: str
    description: str
    interp: Interp


def _spec(unit: str, description: str, interp: Interp = "linear") -> ColumnSpec:
    return ColumnSpec(unit, description, interp)


COLUMNS: dict[str, ColumnSpec] = {
    "p": _spec("rad/s", "body roll rate (FRD x)"),
    "q": _spec("rad/s", "body pitch rate (FRD y)"),
    "r": _spec("rad/s", "body yaw rate (FRD z)"),
    "roll": _spec("rad", "roll angle (ZYX Euler)", "angle"),
    "pitch": _spec("rad", "pitch angle (ZYX Euler)", "angle"),
    "yaw": _spec("rad", "yaw angle (ZYX Euler), NED heading", "angle"),
    "u_roll": _spec("1", "roll loop command, -1..1", "hold"),
    "u_pitch": _spec("1", "pitch loop command, -1..1", "hold"),
    "u_yaw": _spec("1", "yaw loop command, -1..1", "hold"),
    "u_thrust": _spec("1", "collective thrust command, 0..1", "hold"),
    "sp_p": _spec("rad/s", "roll rate setpoint", "hold"),
    "sp_q": _spec("rad/s", "pitch rate setpoint", "hold"),
    "sp_r": _spec("rad/s", "yaw rate setpoint", "hold"),
    "sp_roll": _spec("rad", "roll angle setpoint (attitude loop command)", "hold"),
    "sp_pitch": _spec("rad", "pitch angle setpoint (attitude loop command)", "hold"),
    "sp_yaw": _spec("rad", "yaw angle setpoint (attitude loop command), NED", "hold"),
    "alt": _spec("m", "height above ground (rangefinder, else -z local)"),
    "vx": _spec("m/s", "velocity north (NED)"),
    "vy": _spec("m/s", "velocity east (NED)"),
    "vz": _spec("m/s", "velocity down (NED)"),
    "ax": _spec("m/s²", "specific force, body x (FRD)"),
    "ay": _spec("m/s²", "specific force, body y (FRD)"),
    "az": _spec("m/s²", "specific force, body z (FRD)"),
    "vbat": _spec("V", "battery voltage"),
    "landed": _spec("1", "autopilot land detector: 1 on the ground (or disarmed), "
                         "0 airborne", "hold"),
    "ground_contact": _spec("1", "land detector's touch-down stages: 1 at ground contact or "
                                 "maybe-landed (PX4), 0 otherwise", "hold"),
    **{f"m{i}": _spec("1", f"motor {i} output, 0..1", "hold") for i in range(1, 9)},
}
"""Every FlightTable column, in canonical order."""

RATE_COLUMNS = ("p", "q", "r")
SEGMENT = "segment"
"""Integer column numbering contiguous stretches; a new segment starts after a gap."""

GAP_PERIODS = 5.0
"""A source signal whose samples are further apart than this many native periods has a gap."""

ATTRS_KEYS = (
    "source",  # path of the log
    "format",  # reader name: tlog, bin, ulog, ros1, ros2, mcap, sim, table
    "start_time",  # absolute time of t=0 (Unix s) when the log knows it, else None
    "rate_hz",  # grid rate of the table
    "mapping",  # column -> "TOPIC.FIELD" actually used
    "signals",  # column -> {"source", "count", "rate_hz"}
    "dropped",  # list of {"reason", "count", "signal"}: samples removed
    "repaired",  # list of {"reason", "count", "signal"}: samples fixed (e.g. clock steps)
    "gaps",  # list of {"start", "end", "signal"} in table seconds
    "warnings",  # human-readable notes
    "motor_layout",  # {"x", "y" (m, FRD), "spin" (+1 CCW from above)} per motor m1…mN, if known
    # where the log states them (absent otherwise; etsid.ingest.vehicle):
    # "vehicle" (quadrotor, fixed wing, …), "autopilot" (PX4, ArduPilot), "firmware"
    # (v1.11.2-dev (8583f1da), ArduPlane V3.10.0-dev (f2b4e06a)), "hardware" (board)
)


def validate(table: pd.DataFrame) -> pd.DataFrame:
    """Check that ``table`` follows the FlightTable contract and return it.

    Raises
    ------
    TableError
        Index not named ``t``, not float, not strictly increasing, or a known column
        that is not numeric or holds inf.
    """
    import pandas as pd

    if table.index.name != "t":
        raise TableError(f"table index must be named 't' (seconds), got {table.index.name!r}")
    t = np.asarray(table.index, dtype=float)
    if t.size and not np.all(np.isfinite(t)):
        raise TableError("table time index 't' holds NaN or inf")
    if t.size > 1 and not np.all(np.diff(t) > 0):
        raise TableError("table time index 't' is not strictly increasing")
    # the same columns without attrs: pandas deep-copies attrs into every column it hands out
    view = pd.DataFrame(table, copy=False)
    for name in view.columns:
        if name in COLUMNS:
            col = view[name]
            if not pd.api.types.is_float_dtype(col):
                raise TableError(f"column {name!r} must be float64, got {col.dtype}")
            if np.isinf(col.to_numpy()).any():
                raise TableError(f"column {name!r} holds inf")
    return table


def ordered_columns(names: list[str] | pd.Index) -> list[str]:
    """Known columns in canonical order, then ``segment``, then anything else sorted."""
    names = list(names)
    known = [c for c in COLUMNS if c in names]
    rest = sorted(c for c in names if c not in COLUMNS and c != SEGMENT)
    return known + ([SEGMENT] if SEGMENT in names else []) + rest


# ---------------------------------------------------------------------------
# storage


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        value = float(obj)
        return value if np.isfinite(value) else None
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    return obj


ATTRS_META_KEY = b"etsid.attrs"


def save_table(table: pd.DataFrame, path: str | Path) -> Path:
    """Write a FlightTable as Parquet (provenance in the file metadata) or CSV.

    CSV keeps provenance in a sidecar ``<name>.attrs.json``.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = Path(path)
    frame = table.reset_index()
    attrs = json.dumps(_jsonable(dict(table.attrs)))
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        arrow = pa.Table.from_pandas(frame, preserve_index=False)
        meta = dict(arrow.schema.metadata or {})
        meta.pop(b"pandas", None)
        meta[ATTRS_META_KEY] = attrs.encode()
        pq.write_table(arrow.replace_schema_metadata(meta), path)
    elif suffix == ".csv":
        frame.to_csv(path, index=False, float_format="%.9g")
        path.with_name(path.name + ".attrs.json").write_text(attrs)
    else:
        raise TableError(f"{path}: unknown table format {suffix!r} (use .parquet or .csv)")
    return path


def load_table(path: str | Path) -> pd.DataFrame:
    """Read a table saved by :func:`save_table` (or any CSV/Parquet with a ``t`` column).

    A table without a ``t`` column gets ``t`` = row number (s) and a warning in attrs. The
    attrs are checked against :data:`etsid.schemas.TABLE_ATTRS` and their strings (and the
    column names) made printable (:func:`etsid.escape.clean`).
    """
    import pandas as pd

    path = Path(path)
    suffix = path.suffix.lower()
    attrs: dict[str, Any] = {}
    _check_bounds(path, suffix)
    try:
        if suffix == ".parquet":
            arrow = files.read_parquet(path, "table", TableError)
            meta = arrow.schema.metadata or {}
            if ATTRS_META_KEY in meta:
                attrs = files.loads_json(meta[ATTRS_META_KEY], f"{path} (etsid.attrs)",
                                         TableError, "table attrs")
            frame = arrow.to_pandas()
        elif suffix == ".csv":
            frame = files.read_csv(path, "table", TableError)
            side = path.with_name(path.name + ".attrs.json")
            if os.path.lexists(side):
                attrs = files.read_json(side, "sidecar", TableError, "table attrs")
        else:
            raise TableError(f"{path}: unknown table format {suffix!r} (use .parquet or .csv)")
    except TableError:
        raise
    except FileNotFoundError as err:
        raise TableError(f"{path}: no such file") from err
    except Exception as err:  # pyarrow/pandas raise many types for broken files
        first = str(err).splitlines()[0][:200] if str(err) else type(err).__name__
        raise TableError(f"{path}: not a readable {suffix[1:]} table ({first})") from err
    where = f"{path} (etsid.attrs)" if suffix == ".parquet" else path.name + ".attrs.json"
    attrs = escape.clean(schemas.validate(attrs, schemas.TABLE_ATTRS, where, TableError,
                                          "table attrs"))
    frame.columns = [escape.printable(c) if isinstance(c, str) else c for c in frame.columns]
    warnings = list(attrs.get("warnings", []))
    if "t" in frame.columns:
        frame = frame.set_index("t")
    elif frame.index.name != "t":
        frame.index = pd.Index(np.arange(len(frame), dtype=float), name="t")
        warnings.append(f"{path.name}: no 't' column, using the row number as t (s)")
    try:
        frame.index = frame.index.astype(float)
    except (TypeError, ValueError) as err:
        raise TableError(f"{path}: time column 't' is not numeric ({err})") from err
    numeric = frame.select_dtypes(include="number").columns
    frame[numeric] = frame[numeric].astype(float)
    if SEGMENT in frame.columns:
        frame[SEGMENT] = frame[SEGMENT].astype(np.int64)
    attrs.setdefault("source", str(path))
    attrs.setdefault("format", "table")
    attrs["warnings"] = warnings
    frame.attrs = attrs
    try:
        return validate(frame)
    except TableError as err:
        raise TableError(f"{path}: {err}") from err


MAX_TABLE_COLUMNS = 10_000
"""Columns a table may have (a FlightTable has about 30)."""
MAX_LINE_BYTES = 1 << 20
"""Length of a CSV table's header line, bytes."""


def _check_bounds(path: Path, suffix: str) -> None:
    """Refuse, before parsing, what would make reading a table unbounded: not a regular
    file (a FIFO or device never ends), more than :data:`MAX_TABLE_COLUMNS` columns, a
    CSV header line longer than :data:`MAX_LINE_BYTES`."""
    if suffix not in (".csv", ".parquet"):
        return
    if suffix == ".csv":
        with files.open_binary(path, "table", TableError) as handle:
            header = handle.readline(MAX_LINE_BYTES + 1)
        if len(header) > MAX_LINE_BYTES:
            raise TableError(f"{path}: the header line is longer than "
                             f"{MAX_LINE_BYTES >> 20} MiB: not a table etsid reads")
        columns = header.count(b",") + 1
    else:
        try:
            columns = files.parquet_metadata(path, "table", TableError).num_columns
        except TableError:
            raise
        except Exception as err:  # pyarrow raises many types for broken files
            first = str(err).splitlines()[0][:200] if str(err) else type(err).__name__
            raise TableError(f"{path}: not a readable parquet table ({first})") from err
    if columns > MAX_TABLE_COLUMNS:
        raise TableError(f"{path}: {columns} columns, more than the {MAX_TABLE_COLUMNS} a "
                         "table may have")


def is_table_path(path: str | Path) -> bool:
    """True for files that :func:`load_table` reads (``.parquet``, ``.csv``)."""
    return Path(path).suffix.lower() in (".parquet", ".csv")
