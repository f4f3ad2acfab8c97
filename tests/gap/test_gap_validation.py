"""The evidence splits of etsid/gap/validation.py."""

from __future__ import annotations

import numpy as np

from etsid.gap.validation import time_split


def test_time_split_is_first_share_then_rest() -> None:
    mask = np.ones(100, dtype=bool)
    mask[:10] = False
    fit, score = time_split(mask, 0.6)
    assert fit.sum() == 54 and score.sum() == 36
    assert np.flatnonzero(fit).max() < np.flatnonzero(score).min()
