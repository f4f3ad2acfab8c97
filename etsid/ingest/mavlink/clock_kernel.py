"""The clock walk of :mod:`etsid.ingest.mavlink.clock` compiled by numba, and the placing of
one message's frames in logged order for it (:func:`place_clock`), in their own module so
that reading a small tlog need not import numba."""

from __future__ import annotations

import numba
import numpy as np

from etsid.ingest.mavlink.clock import NONE, _walk

walk = numba.njit(cache=True)(_walk)
""":func:`etsid.ingest.mavlink.clock._walk`, compiled (same arithmetic)."""


@numba.njit(cache=True, nogil=True)
def place_clock(at, stamp, field, scale, kind_code, unix_from, gcs, value, kind
                ):  # pragma: no cover - compiled
    """Frame ``i`` of one message to its place ``at[i]`` in logged order: ground-station
    time ``stamp[i] · 1e-6`` s into ``gcs``, its own clock ``field[i] · scale`` s into
    ``value`` (0 when ``kind_code`` is NONE: the message has none) and ``kind_code`` into
    ``kind``, or NONE where ``field[i] > unix_from`` (> 0: a µs clock in Unix time). The
    arithmetic of numpy's ``stamp * 1e-6`` and ``field.astype(float) * scale``."""
    for i in range(at.size):
        j = at[i]
        gcs[j] = np.float64(stamp[i]) * 1e-6
        if kind_code == NONE:
            value[j] = 0.0
            kind[j] = NONE
            continue
        x = field[i]
        value[j] = np.float64(x) * scale
        kind[j] = NONE if unix_from > 0 and x > unix_from else kind_code
