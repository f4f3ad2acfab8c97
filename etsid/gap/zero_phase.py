"""Zero-phase second-order-section filtering of many series at once (numba kernel).

:func:`filtfilt_columns` does what :func:`scipy.signal.sosfiltfilt` does with an odd
extension (the steps of :func:`etsid.gap.signals.lowpass`) and gives its answer bit for
bit: each sample goes through the same multiplications and additions, in the same order,
as scipy's own section kernel. What differs is the loop order: the columns of an
(n, k) array advance together, sample by sample, so the k independent recursions overlap
in the processor instead of running one after another (2-3× faster for the three or
four channels of a candidate's prediction).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, boundscheck=False)
def _passes(sos: np.ndarray, zi: np.ndarray, ext: np.ndarray) -> None:  # pragma: no cover
    """Forward then backward pass over ``ext`` (N, k) in place, each from steady state
    ``zi`` (sections, 2) scaled by the pass's first sample (numba)."""
    n_len, k = ext.shape
    n_sec = sos.shape[0]
    z = np.empty((n_sec, 2, k))
    for direction in range(2):
        start = 0 if direction == 0 else n_len - 1
        step = 1 if direction == 0 else -1
        for s in range(n_sec):
            for j in range(k):
                z[s, 0, j] = zi[s, 0] * ext[start, j]
                z[s, 1, j] = zi[s, 1] * ext[start, j]
        i = start
        for _ in range(n_len):
            for j in range(k):
                x_cur = ext[i, j]
                for s in range(n_sec):
                    x_new = sos[s, 0] * x_cur + z[s, 0, j]
                    z[s, 0, j] = sos[s, 1] * x_cur - sos[s, 4] * x_new + z[s, 1, j]
                    z[s, 1, j] = sos[s, 2] * x_cur - sos[s, 5] * x_new
                    x_cur = x_new
                ext[i, j] = x_cur
            i += step


def filtfilt_columns(columns, sos: np.ndarray, zi: np.ndarray, edge: int) -> np.ndarray:
    """(n, k) ``columns`` (a 2-D array, or a list of k 1-D series of length n) filtered
    forward and backward along time after an odd extension of ``edge`` samples at both ends
    (``zi``: the sections' steady-state initial conditions for a unit input,
    :func:`scipy.signal.sosfilt_zi`); n > edge."""
    series = list(columns.T) if isinstance(columns, np.ndarray) else columns
    n = series[0].shape[0]
    ext = np.empty((n + 2 * edge, len(series)))
    for j, x in enumerate(series):  # the signal mirrored through its end points
        ext[:edge, j] = 2 * x[:1] - x[edge:0:-1]
        ext[edge:edge + n, j] = x
        ext[edge + n:, j] = 2 * x[-1:] - x[-2:-edge - 2:-1]
    _passes(np.ascontiguousarray(sos, dtype=float), np.ascontiguousarray(zi, dtype=float), ext)
    return ext[edge:edge + n]
