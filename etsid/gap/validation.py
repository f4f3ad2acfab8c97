"""How REAL's evidence is split into a part to fit on and a part to score on.

* :func:`time_split` — the first ``share`` of the airborne time to fit, the rest to score:
  tests extrapolation in time (a sagging pack, a warming motor), but an effect that shows
  only in some stretch of the flight (a low dwell at the start) may barely occur in the
  scored part.
* :func:`blocked_split` — contiguous blocks (``block_s``) with a gap (``gap_s``) dropped
  between neighbours so that the low-pass filter does not carry samples across; the
  blocks are ranked by how far REAL departs from the nominal model in them and dealt to
  fit and score alternately along that ranking. Wherever the mismatch lives (a low dwell,
  a fast stretch, a quarter of the flight), it is both fitted and scored.
"""

from __future__ import annotations

import numpy as np

from etsid.gap.signals import true_runs

BLOCK_S = 2.0
GAP_S = 0.5


def time_split(mask: np.ndarray, share: float) -> tuple[np.ndarray, np.ndarray]:
    """(fit, score) masks: the first ``share`` of the True samples, and the rest."""
    idx = np.flatnonzero(mask)
    cut = idx[int(share * idx.size)] if idx.size else 0
    before = mask & (np.arange(mask.size) < cut)
    return before, mask & ~before


def blocked_split(mask: np.ndarray, fs: float, departure: np.ndarray,
                  block_s: float = BLOCK_S, gap_s: float = GAP_S
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(fit, score) masks from contiguous blocks of the airborne runs in ``mask``.

    Parameters
    ----------
    mask : ndarray of bool
        The evidence (REAL's airborne samples).
    fs : float
        Sample rate, Hz.
    departure : ndarray
        Per-sample size of REAL's departure from the nominal model (e.g. the sum over the
        mismatched channels of residual² / floor²); blocks are ranked by its mean.
    block_s, gap_s : float
        Block length and the gap dropped at the start of every block, s.

    Returns
    -------
    fit, score : ndarray of bool
        Disjoint masks; blocks alternate between them along the ranking (the block that
        departs most goes to fit, the next to score, …).
    """
    n_block = max(round(block_s * fs), 2)
    n_gap = round(gap_s * fs)
    blocks = []
    for a, b in true_runs(mask):
        for start in range(a, b, n_block):
            lo, hi = start + n_gap, min(start + n_block, b)
            if hi - lo >= max(n_block // 4, 1):
                blocks.append((lo, hi))
    fit = np.zeros(mask.size, dtype=bool)
    score = np.zeros(mask.size, dtype=bool)
    ranked = sorted(blocks, key=lambda ab: -float(np.mean(departure[ab[0]:ab[1]])))
    for i, (lo, hi) in enumerate(ranked):
        (fit if i % 2 == 0 else score)[lo:hi] = True
    return fit, score
