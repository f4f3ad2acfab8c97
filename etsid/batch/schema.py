"""The result row of one log: one fixed Arrow schema for every command.

Every row file of ``DIR/results/`` has exactly this schema, so pandas, Dask and DuckDB read
the whole dataset (all commands, all rows) without reconciling schemas. Columns a command
does not fill are null. Per-output figures of the rate model (``p q r``) have their own
columns; the full metrics.json of an identification is kept in ``metrics_json``.
"""

from __future__ import annotations

from typing import Any

import pyarrow as pa

RATE_OUTPUTS = ("p", "q", "r")
"""Outputs whose figures get their own columns (the default rate model)."""

_FIELDS: list[tuple[str, pa.DataType, str]] = [
    ("input", pa.string(), "the log as given (path or URL); for gap, the real log"),
    ("input_sha256", pa.string(), "SHA-256 of the log's bytes (a bag: its files in name order)"),
    ("sim_input", pa.string(), "gap: the simulated log of the pair"),
    ("sim_sha256", pa.string(), "gap: SHA-256 of the simulated log"),
    ("options_digest", pa.string(), "SHA-256 of the command and its options"),
    ("status", pa.string(), "ok or error"),
    ("error", pa.string(), "one-line error of a failed log"),
    ("error_kind", pa.string(), "class of the error (IngestError, IdentError, …)"),
    ("format", pa.string(), "log format (tlog, ulog, ros1, …)"),
    ("run_dir", pa.string(), "this log's directory, relative to the batch directory"),
    ("duration_s", pa.float64(), "time span of the log, s"),
    ("airborne_s", pa.float64(), "time in the air, s (identify's airborne segments)"),
    ("vehicle", pa.string(), "vehicle type where the log says (quadrotor, fixed wing, …)"),
    ("autopilot", pa.string(), "autopilot where the log says (PX4, ArduPilot, …)"),
    ("firmware", pa.string(), "firmware version where the log says"),
    ("hardware", pa.string(), "flight controller board where the log says"),
    ("start_time", pa.float64(), "UTC start of the log, s since 1970, where known"),
    ("rows", pa.int64(), "rows of the FlightTable"),
    ("rate_hz", pa.float64(), "grid rate of the FlightTable, Hz"),
    ("columns", pa.string(), "FlightTable columns, comma-separated"),
    ("channels", pa.int64(), "inspect: topics/messages in the log"),
    ("warnings", pa.int64(), "notes and warnings reading (and identifying) the log"),
    ("n_samples", pa.int64(), "identify: usable regression rows"),
    ("rules_final", pa.int64(), "identify: rules after the whole log"),
    ("rules_peak", pa.int64(), "identify: most rules at any time"),
    ("rules_frozen", pa.int64(), "identify: rules of the saved (frozen) model"),
    ("input_family", pa.string(), "identify: input family of the rate model"),
    ("fit_online", pa.float64(), "identify: online fit, %, mean over outputs"),
    ("fit_one_step", pa.float64(), "identify: validation one-step fit, %, mean over the "
                                   "informative outputs"),
    ("fit_free_run", pa.float64(), "identify: validation free-run fit, %, mean over the "
                                   "informative outputs that did not diverge"),
    ("ndei_one_step", pa.float64(), "identify: validation one-step NDEI, mean over the "
                                    "informative outputs"),
    *[(f"{y}_fit_one_step", pa.float64(), f"identify: validation one-step fit of {y}, %")
      for y in RATE_OUTPUTS],
    *[(f"{y}_rmse_one_step", pa.float64(), f"identify: validation one-step RMSE of {y}, rad/s")
      for y in RATE_OUTPUTS],
    ("regime_count", pa.int64(), "identify: rules of the saved rule base (rules.json)"),
    ("regimes", pa.string(), "identify: each rule's focal point in the scheduling variables "
     "(rules.json of a scheduled rule base), rules separated by '; '"),
    ("metrics_json", pa.string(), "identify: the whole metrics.json"),
    ("gap_verdict", pa.string(), "gap: the verdict"),
    ("gap_effects", pa.string(), "gap: effect names, best first, comma-separated"),
    ("gap_json", pa.string(), "gap: the whole gap.json"),
    ("wall_s", pa.float64(), "wall time of this log, s"),
    ("cpu_s", pa.float64(), "CPU time of the worker process during this log (all threads), s"),
    ("peak_rss_mb", pa.float64(), "peak resident memory of the worker during this log, MB"),
    ("worker", pa.string(), "host:pid that ran the log"),
    ("etsid_version", pa.string(), "etsid version of the worker"),
    ("finished", pa.string(), "UTC time the log finished (ISO 8601)"),
]

SCHEMA = pa.schema([pa.field(name, kind, metadata={"doc": doc}) for name, kind, doc in _FIELDS])
"""Arrow schema of a result row (the ``command`` partition column comes from the path)."""

DESCRIPTIONS: dict[str, str] = {name: doc for name, _, doc in _FIELDS}

VOLATILE = ("wall_s", "cpu_s", "peak_rss_mb", "worker", "finished")
"""Columns that differ from run to run of the same batch; every other column is the same
bit for bit whatever the job count or scheduler."""


def empty_row() -> dict[str, Any]:
    """A row with every column null."""
    return dict.fromkeys(SCHEMA.names)


def to_table(rows: list[dict[str, Any]]) -> pa.Table:
    """Rows as an Arrow table of :data:`SCHEMA` (unknown keys are an error)."""
    for row in rows:
        unknown = set(row) - set(SCHEMA.names)
        if unknown:
            raise KeyError(f"not result columns: {', '.join(sorted(unknown))}")
    return pa.Table.from_pylist([{**empty_row(), **row} for row in rows], schema=SCHEMA)
