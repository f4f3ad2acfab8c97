"""The compiled (numba) binning of :func:`etsid.ingest.source_consistency.bin_means`,
imported only once numba is loaded (:mod:`etsid.ingest.kernel_choice`)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, boundscheck=False)
def bin_sums(t: np.ndarray, v: np.ndarray, ok: np.ndarray, lo: float, hi: float,
             per_s: float, counts: np.ndarray, sums: np.ndarray
             ) -> None:  # pragma: no cover - compiled
    """Count and sum the samples ``v`` where ``ok`` and ``lo ≤ t < hi`` into their bins
    (``counts``, ``sums``: one entry per bin, zero on entry): bin
    ``min(int((t − lo) · per_s), nbins − 1)``, the samples added in order, as
    ``np.bincount`` (with ``weights``) of numpy's bin indices does."""
    last = counts.size - 1
    for i in range(t.size):
        ti = t[i]
        if not ok[i] or not (ti >= lo and ti < hi):
            continue
        k = np.intp((ti - lo) * per_s)
        if k > last:
            k = last
        counts[k] += 1
        sums[k] += v[i]
