"""The compiled (numba) zero-order-hold index of :func:`etsid.ingest.align.hold_index`,
imported only once numba is loaded (:mod:`etsid.ingest.kernel_choice`).

``np.searchsorted(t, grid, side="right") - 1`` bisects ``t`` for every grid point: about
6 ms for 150,000 points. When ``t`` and the grid are both in order and hold no NaN, one
merge walk along both gives the same indices (the count of samples at or before each
point, less one) in a fraction of that.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, boundscheck=False)
def hold_merge(t: np.ndarray, grid: np.ndarray, out: np.ndarray
               ) -> bool:  # pragma: no cover - compiled
    """``out[i]`` = index of the last ``t`` at or before ``grid[i]`` (−1 before the first),
    by one walk; False (``out`` unspecified) when ``t`` or ``grid`` is out of order or
    holds a NaN."""
    for i in range(1, t.size):
        if not t[i] >= t[i - 1]:
            return False
    for i in range(grid.size):
        if np.isnan(grid[i]) or (i > 0 and not grid[i] >= grid[i - 1]):
            return False
    if t.size and np.isnan(t[0]):
        return False
    j = 0
    n = t.size
    for i in range(grid.size):
        g = grid[i]
        while j < n and t[j] <= g:
            j += 1
        out[i] = j - 1
    return True
