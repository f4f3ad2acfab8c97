"""Least and greatest value of every column of a 2-D array in one pass (numba).

numpy reduces an (N, n) row-major array along its rows one short row at a time: with 3 or
38 columns its ``min(axis=0)`` and ``max(axis=0)`` (and their NaN forms) cost about 1 ms
each per 20,000 rows, and identify takes them a dozen times (the normalisation ranges of
every fit, the divergence envelope of every free run). Min and max are exact, so one pass
gives the same numbers (a column holding both −0.0 and 0.0 may give the other zero).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, boundscheck=False)
def _bounds_kernel(A: np.ndarray, lo: np.ndarray, hi: np.ndarray, check: np.ndarray
                   ) -> None:  # pragma: no cover - compiled
    """Running min and max per column, and ``check[j]`` = Σ (v − v): NaN when the column
    holds a NaN or an infinity, else 0. Branch-free, so the column loop vectorises."""
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            v = A[i, j]
            lo[j] = v if v < lo[j] else lo[j]
            hi[j] = v if v > hi[j] else hi[j]
            check[j] += v - v


def column_bounds(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """Per column of ``A`` (N, n): the least and greatest value ignoring NaN (NaN for a
    column of NaN only, as ``np.nanmin``/``np.nanmax``), and whether every value is
    finite. One numba pass when every value is finite, else numpy's."""
    A = np.ascontiguousarray(A, dtype=np.float64)
    n = A.shape[1]
    if len(A):
        lo, hi, check = np.full(n, np.inf), np.full(n, -np.inf), np.zeros(n)
        _bounds_kernel(A, lo, hi, check)
        if not np.isnan(check).any():
            return lo, hi, True
    with np.errstate(invalid="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: NaN
            return np.nanmin(A, axis=0), np.nanmax(A, axis=0), False
