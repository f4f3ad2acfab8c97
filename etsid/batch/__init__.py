"""Batches: one command over a fleet's logs, on all cores or a Dask cluster.

>>> from etsid.batch import COMMANDS, SCHEMA
>>> COMMANDS
('inspect', 'ingest', 'identify', 'gap')
>>> SCHEMA.field("input_sha256").type
DataType(string)
"""

from __future__ import annotations

from etsid.batch.inputs import find_inputs, read_pairs
from etsid.batch.results import read_results
from etsid.batch.run import (
    EXIT_ALL_FAILED,
    SCHEDULERS,
    BatchSummary,
    default_jobs,
    run_batch,
)
from etsid.batch.schema import SCHEMA, VOLATILE
from etsid.batch.spec import COMMANDS, BatchSpec
from etsid.batch.tasks import GAP_UNAVAILABLE, gap_available
from etsid.errors import BatchError

__all__ = [
    "COMMANDS",
    "EXIT_ALL_FAILED",
    "GAP_UNAVAILABLE",
    "SCHEDULERS",
    "SCHEMA",
    "VOLATILE",
    "BatchError",
    "BatchSpec",
    "BatchSummary",
    "default_jobs",
    "find_inputs",
    "gap_available",
    "read_pairs",
    "read_results",
    "run_batch",
]
