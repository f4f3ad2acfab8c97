"""The results dataset ``DIR/results/``: one Parquet file per log, Hive-partitioned by command.

Layout::

    DIR/results/command=identify/<sha256[:32]>-<options[:12]>-<path[:8]>.parquet
    DIR/results/command=identify/part-<random16>.parquet     (compacted rows)

One file per log is written atomically (unique temporary name, then rename) as soon as the
log finishes, so a batch stopped at any moment leaves only whole rows. A finished batch
whose partition holds :data:`COMPACT_AT` files or more merges them into part files
(:func:`compact`). ``--resume`` reads the rows (input hash, options digest, status) to
know what is done. ``pandas.read_parquet(DIR/"results")``, ``dask.dataframe.read_parquet`` and
DuckDB's ``read_parquet('DIR/results/*/*.parquet', hive_partitioning = true)`` read the
dataset as it is; :func:`read_results` adds the row order and the schema.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import uuid
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.dataset as ds
import pyarrow.parquet as pq

from etsid.batch.schema import SCHEMA, to_table
from etsid.errors import BatchError
from etsid.ident.rundir import os_reason

RESULTS = "results"
RUNS = "runs"


def results_dir(out: str | Path) -> Path:
    """``DIR/results``."""
    return Path(out) / RESULTS


def partition_dir(out: str | Path, command: str) -> Path:
    """``DIR/results/command=COMMAND``."""
    return results_dir(out) / f"command={command}"


def row_name(key: str | None, options_digest: str, item: str) -> str:
    """File name of a row: result key (the input hash; for a pair, the hash of both
    hashes), options digest and the digest of the input's path."""
    path_digest = hashlib.sha256(item.encode()).hexdigest()[:8]
    return f"{(key or 'nohash')[:32]}-{options_digest[:12]}-{path_digest}.parquet"


def _unique_tmp(directory: Path, name: str) -> Path:
    """A fresh hidden temporary file beside ``name`` (unique across processes and hosts)."""
    handle, tmp = tempfile.mkstemp(prefix=f".{name}.", suffix=".tmp", dir=directory)
    os.close(handle)
    return Path(tmp)


def write_table_atomic(table: pa.Table, path: Path, what: str) -> Path:
    """Write ``table`` to ``path`` whole: a unique temporary file, then a rename; on any
    error (a full disk) the temporary file is removed and a one-line :class:`BatchError`
    says what could not be written."""
    tmp: Path | None = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = _unique_tmp(path.parent, path.name)
        pq.write_table(table, tmp)
        os.replace(tmp, path)
    except OSError as err:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        raise BatchError(f"{path.parent}: cannot write {what} ({os_reason(err)})") from err
    except BaseException:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
        raise
    return path


def write_row(out: str | Path, command: str, row: dict[str, Any], key: str | None) -> Path:
    """Write one result row as its own Parquet file (atomic rename); returns the file.

    Raises
    ------
    BatchError
        The row could not be written (nothing partial is left).
    """
    directory = partition_dir(out, command)
    item = f"{row.get('sim_input') or ''},{row['input']}"
    path = directory / row_name(key, row["options_digest"], item)
    return write_table_atomic(to_table([row]), path, "a result row")


def result_key(input_sha256: str | None, sim_sha256: str | None) -> str | None:
    """The resume key of a row: the input hash, or for a pair the hash of both hashes."""
    if not input_sha256:
        return None
    if sim_sha256:
        return hashlib.sha256(f"{sim_sha256}:{input_sha256}".encode()).hexdigest()
    return input_sha256


def _dataset(root: Path) -> ds.Dataset:
    partitioning = ds.partitioning(pa.schema([("command", pa.string())]), flavor="hive")
    schema = pa.schema([pa.field("command", pa.string()), *SCHEMA])
    files = sorted(str(p) for p in root.glob("command=*/*.parquet"))
    return ds.dataset(files, format="parquet", partitioning=partitioning, schema=schema,
                      partition_base_dir=str(root))


def done_keys(out: str | Path, command: str, options_digest: str,
              retry_failed: bool = True) -> frozenset[str]:
    """Result keys (32 hex digits) that ``--resume`` skips for ``options_digest``: the logs
    with an ``ok`` row, and with ``retry_failed=False`` (``--skip-failed``) those with an
    error row too. A log whose worker died has no hash and always runs again."""
    root = results_dir(out)
    if not partition_dir(out, command).is_dir():
        return frozenset()
    wanted = (ds.field("command") == command) & (ds.field("options_digest") == options_digest)
    table = _dataset(root).to_table(columns=["input_sha256", "sim_sha256", "status",
                                             "finished"], filter=wanted)
    latest: dict[str, tuple[str, str]] = {}
    for sha, sim, status, finished in zip(*(table.column(i).to_pylist() for i in range(4)),
                                          strict=True):
        key = result_key(sha, sim)
        if key is not None and (key[:32] not in latest
                                or (finished or "") >= latest[key[:32]][1]):
            latest[key[:32]] = (status, finished or "")
    return frozenset(key for key, (status, _) in latest.items()
                     if status == "ok" or not retry_failed)


COMPACT_AT = 256
"""Row files in a partition from which a finished batch compacts them into part files."""

PART_ROWS = 256
"""Rows per part file of a compacted partition (what the compaction holds in memory at a
time: a few tens of MB of rows with their metrics)."""


def _latest_indices(table: pa.Table) -> pa.Array:
    """Row indices of ``table`` keeping one row per log (:data:`ROW_IDENTITY`), the latest
    ``finished``."""
    ident = [c for c in ROW_IDENTITY if c in table.column_names and c != "command"]
    indexed = table.select([*ident, "finished"]).append_column(
        "_row", pa.array(range(table.num_rows), pa.int64()))
    ordered = indexed.sort_by([("finished", "ascending"), ("_row", "ascending")])
    ordered = ordered.append_column("_rank", pa.array(range(ordered.num_rows), pa.int64()))
    last = ordered.group_by(ident, use_threads=False).aggregate([("_rank", "max")])
    ranks = pc.sort_indices(last.column("_rank_max"))
    return pc.take(ordered.column("_row"),
                           pc.take(last.column("_rank_max"), ranks))


def compact(out: str | Path, command: str, min_files: int = COMPACT_AT,
            part_rows: int = PART_ROWS) -> int:
    """Merge the row files of ``DIR/results/command=COMMAND`` into part files of at most
    ``part_rows`` rows (one row per log, the latest), when there are ``min_files`` or
    more. Each part is written whole before the files it replaces are removed: stopped
    at any moment, the dataset holds every row (at worst twice, which
    :func:`read_results` resolves). Returns the number of files merged.
    """
    directory = partition_dir(out, command)
    files = sorted(directory.glob("*.parquet")) if directory.is_dir() else []
    if len(files) < max(2, min_files):
        return 0
    merged = 0
    for first in range(0, len(files), part_rows):
        group = files[first:first + part_rows]
        table = ds.dataset([str(f) for f in group], format="parquet",
                           schema=SCHEMA).to_table()
        table = table.take(_latest_indices(table))
        name = f"part-{uuid.uuid4().hex[:16]}.parquet"
        write_table_atomic(table, directory / name, "a compacted part of the results")
        for path in group:
            path.unlink(missing_ok=True)
        merged += len(group)
        del table
        pa.default_memory_pool().release_unused()  # keep the batch's parent small
    return merged


ROW_IDENTITY = ("command", "options_digest", "sim_input", "input")
"""Columns that name one log's row: where a log has several (a failed log run again by
``--resume`` next to its old row in a compacted file), the latest ``finished`` is kept."""


def latest_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per log (:data:`ROW_IDENTITY`): the one finished last."""
    if frame.empty:
        return frame
    ident = [c for c in ROW_IDENTITY if c in frame.columns]
    order = frame.assign(_order=frame["finished"].fillna("")).sort_values(
        "_order", kind="stable")
    keep = ~order.duplicated(subset=ident, keep="last")
    return order[keep].drop(columns="_order").sort_index()


def read_results(out: str | Path, command: str | None = None) -> pd.DataFrame:
    """The results dataset of a batch directory as one frame, one row per log (the latest),
    sorted by command and input.

    Raises
    ------
    BatchError
        No ``results/`` directory (not a batch directory).
    """
    root = results_dir(out)
    if not root.is_dir():
        raise BatchError(f"{out}: not a batch directory (no results/; run `etsid batch`)")
    table = _dataset(root).to_table(filter=None if command is None
                                    else ds.field("command") == command)
    frame = latest_rows(table.to_pandas())
    return frame.sort_values(["command", "input"], kind="stable").reset_index(drop=True)
