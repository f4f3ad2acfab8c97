"""Batches: one command over a fleet's logs, on all cores or a Dask cluster.

>>> from etsid.batch import COMMANDS, SCHEMA
>>> COMMANDS
('inspect', 'ingest', 'identify', 'gap')
>>> SCHEMA.field("input_sha256").type
DataType(string)
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from etsid.errors import BatchError

if TYPE_CHECKING:  # pragma: no cover
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

_LAZY = {**dict.fromkeys(("find_inputs", "read_pairs"), "etsid.batch.inputs"),
         "read_results": "etsid.batch.results",
         **dict.fromkeys(("EXIT_ALL_FAILED", "SCHEDULERS", "BatchSummary", "default_jobs",
                          "run_batch"), "etsid.batch.run"),
         **dict.fromkeys(("SCHEMA", "VOLATILE"), "etsid.batch.schema"),
         **dict.fromkeys(("COMMANDS", "BatchSpec"), "etsid.batch.spec"),
         **dict.fromkeys(("GAP_UNAVAILABLE", "gap_available"), "etsid.batch.tasks")}
"""Public names → the module that defines them, imported when the name is first used:
importing the package (or :mod:`etsid.batch.limits`, which ``etsid batch --help`` uses)
loads no numpy or pyarrow."""


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is not None:
        return getattr(importlib.import_module(module), name)
    raise AttributeError(f"module 'etsid.batch' has no attribute {name!r}")


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
