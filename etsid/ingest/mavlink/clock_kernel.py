"""The clock walk of :mod:`etsid.ingest.mavlink.clock` compiled by numba, in its own module
so that reading a small tlog need not import numba."""

from __future__ import annotations

import numba

from etsid.ingest.mavlink.clock import _walk

walk = numba.njit(cache=True)(_walk)
""":func:`etsid.ingest.mavlink.clock._walk`, compiled (same arithmetic)."""
