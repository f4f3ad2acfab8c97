"""The compiled (numba) ULog message walkers of :mod:`etsid.ingest.ulog_clean`, imported
only when they are needed (:mod:`etsid.ingest.kernel_choice`)."""

from __future__ import annotations

from etsid.ingest import ulog_clean
from etsid.ingest.kernel_choice import compiled

chain = compiled(ulog_clean._chain)
resync = compiled(ulog_clean._resync)
