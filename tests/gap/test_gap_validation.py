"""The evidence splits of etsid/gap/validation.py."""

from __future__ import annotations

import numpy as np
import pytest

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


class _KnownPrediction:
    """A nominal model whose prediction is a fixed series (the response statistic only reads
    ``predict``)."""

    def __init__(self, x: np.ndarray) -> None:
        self.x = x

    def predict(self, flight, mods=None, channels=None) -> dict[str, np.ndarray]:
        return {"p": self.x}


def test_response_gain_recovers_a_known_gain_and_its_standard_error() -> None:
    """y = 0.8 x + white noise at 100 Hz: the gain is 0.8 within its standard error, and the
    t of a gain of 1 matches the textbook slope error with two samples per period of the
    8 Hz cut-off (n_eff = N · 16 / 100)."""
    from types import SimpleNamespace

    from etsid.gap.floors import response_gains

    rng = np.random.default_rng(3)
    n, fs = 20000, 100.0
    x = rng.normal(0.0, 2.0, n)
    y = 0.8 * x + rng.normal(0.0, 1.0, n)
    flight = SimpleNamespace(airborne=np.ones(n, dtype=bool), fs=fs)
    gain, t = response_gains(flight, _KnownPrediction(x), {"p": y}, ("p",))["p"]
    se = np.sqrt(1.0 / (4.0 * n * 16.0 / fs))  # σ_e² / (σ_x² n_eff)
    assert abs(gain - 0.8) < 3 * se * np.sqrt(16.0 / fs)  # the white-noise error is smaller
    assert t == pytest.approx((gain - 1.0) / se, rel=0.05)
    same, t_same = response_gains(flight, _KnownPrediction(x), {"p": x + rng.normal(0, 1, n)},
                                  ("p",))["p"]
    assert abs(t_same) < 3.0 and same == pytest.approx(1.0, abs=0.02)
