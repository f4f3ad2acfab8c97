"""The evidence splits of etsid/gap/validation.py."""

from __future__ import annotations

import numpy as np

from etsid.gap.validation import blocked_split, time_split


def test_time_split_is_first_share_then_rest() -> None:
    mask = np.ones(100, dtype=bool)
    mask[:10] = False
    fit, score = time_split(mask, 0.6)
    assert fit.sum() == 54 and score.sum() == 36
    assert np.flatnonzero(fit).max() < np.flatnonzero(score).min()


def test_blocked_split_scores_where_the_mismatch_lives() -> None:
    """An effect confined to 10 % of a 60 s flight (one stretch at 5–11 s): the time split
    scores none of it; the blocked split fits and scores about half of it each, with gaps
    between neighbouring blocks and disjoint masks."""
    fs = 100.0
    t = np.arange(6000) / fs
    mask = np.ones(t.size, dtype=bool)
    departure = np.where((t >= 5.0) & (t < 11.0), 50.0, 1.0)
    _, score_t = time_split(mask, 0.6)
    assert departure[score_t].max() == 1.0
    fit, score = blocked_split(mask, fs, departure)
    assert not np.any(fit & score)
    hot = departure > 1.0
    assert 0.3 < (hot & fit).sum() / hot.sum() < 0.6
    assert 0.3 < (hot & score).sum() / hot.sum() < 0.6
    assert (fit | score).sum() == int(0.75 * t.size)  # a 0.5 s gap per 2 s block
