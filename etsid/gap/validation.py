"""How SIM's evidence is split into a part to fit on and a part to score on.

:func:`time_split` takes the first ``share`` of the airborne time to fit and the rest to
score: it tests extrapolation in time (a sagging pack, a warming motor). SIM's own
held-out error, the floors' first term, is measured on it. REAL is scored on blocked folds
instead (:func:`etsid.gap.criterion.make_folds`), so that wherever a mismatch lives it is
both fitted and scored.
"""

from __future__ import annotations

import numpy as np


def time_split(mask: np.ndarray, share: float) -> tuple[np.ndarray, np.ndarray]:
    """(fit, score) masks: the first ``share`` of the True samples, and the rest."""
    idx = np.flatnonzero(mask)
    cut = idx[int(share * idx.size)] if idx.size else 0
    before = mask & (np.arange(mask.size) < cut)
    return before, mask & ~before
