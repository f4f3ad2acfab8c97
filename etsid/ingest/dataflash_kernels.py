"""The compiled (numba) DataFlash indexer of :mod:`etsid.ingest.dataflash_index`, imported
only when it is needed (:mod:`etsid.ingest.kernel_choice`)."""

from __future__ import annotations

from etsid.ingest import dataflash_index as plain
from etsid.ingest.kernel_choice import compiled

_grow = compiled(plain._grow)
_fmt_length = compiled(plain._fmt_length)
index = compiled(plain._index, _grow=_grow, _fmt_length=_fmt_length)
