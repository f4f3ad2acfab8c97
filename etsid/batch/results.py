"""The results dataset ``DIR/results/``: one Parquet file per log, Hive-partitioned by command.

Layout::

    DIR/results/command=identify/<sha256[:32]>-<options[:12]>-<path[:8]>.parquet

One file per log is written atomically (temporary name, then rename) as soon as the log
finishes, so a batch stopped at any moment leaves only whole rows, and ``--resume`` finds
them by name. ``pandas.read_parquet(DIR/"results")``, ``dask.dataframe.read_parquet`` and
DuckDB's ``read_parquet('DIR/results/*/*.parquet', hive_partitioning = true)`` read the
dataset as it is; :func:`read_results` adds the row order and the schema.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq

from etsid.batch.schema import SCHEMA, to_table
from etsid.errors import BatchError

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


def write_row(out: str | Path, command: str, row: dict[str, Any], key: str | None) -> Path:
    """Write one result row as its own Parquet file (atomic rename); returns the file."""
    directory = partition_dir(out, command)
    directory.mkdir(parents=True, exist_ok=True)
    item = f"{row.get('sim_input') or ''},{row['input']}"
    path = directory / row_name(key, row["options_digest"], item)
    tmp = directory / f".{path.name}.{os.getpid()}.tmp"
    pq.write_table(to_table([row]), tmp)
    os.replace(tmp, path)
    return path


def done_keys(out: str | Path, command: str, options_digest: str) -> frozenset[str]:
    """Input hashes that already have a result row for ``options_digest`` (for --resume)."""
    directory = partition_dir(out, command)
    if not directory.is_dir():
        return frozenset()
    keys = set()
    tail = f"-{options_digest[:12]}-"
    for path in directory.glob("*.parquet"):
        sha, sep, _ = path.name.partition(tail)
        if sep and sha != "nohash":
            keys.add(sha)
    return frozenset(keys)


def read_results(out: str | Path, command: str | None = None) -> pd.DataFrame:
    """The results dataset of a batch directory as one frame, sorted by command and input.

    Raises
    ------
    BatchError
        No ``results/`` directory (not a batch directory).
    """
    root = results_dir(out)
    if not root.is_dir():
        raise BatchError(f"{out}: not a batch directory (no results/; run `etsid batch`)")
    partitioning = ds.partitioning(pa.schema([("command", pa.string())]), flavor="hive")
    schema = pa.schema([pa.field("command", pa.string()), *SCHEMA])
    dataset = ds.dataset(str(root), format="parquet", partitioning=partitioning,
                         schema=schema)
    table = dataset.to_table(filter=None if command is None
                             else ds.field("command") == command)
    frame = table.to_pandas()
    return frame.sort_values(["command", "input"], kind="stable").reset_index(drop=True)
