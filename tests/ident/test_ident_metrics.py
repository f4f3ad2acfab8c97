"""Metrics against hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.ident.metrics import fit_percent, ndei, rmse, scores, vaf


def test_known_values() -> None:
    y = np.array([0.0, 2.0, 4.0, 6.0])
    yhat = np.array([1.0, 2.0, 3.0, 6.0])
    assert rmse(y, yhat) == pytest.approx(np.sqrt(0.5))
    assert ndei(y, yhat) == pytest.approx(np.sqrt(0.5) / np.sqrt(5.0))
    # residuals (-1, 0, 1, 0): variance 0.5; var(y) = 5
    assert vaf(y, yhat) == pytest.approx(90.0)
    assert fit_percent(y, yhat) == pytest.approx(100 * (1 - np.sqrt(2) / np.sqrt(20)))


def test_perfect_and_mean_predictions() -> None:
    y = np.sin(np.linspace(0, 6, 50))
    assert fit_percent(y, y) == 100.0
    assert vaf(y, y) == 100.0
    assert fit_percent(y, np.full_like(y, y.mean())) == pytest.approx(0.0, abs=1e-12)


def test_nan_pairs_are_ignored_and_counted() -> None:
    y = np.array([1.0, np.nan, 3.0, 5.0])
    yhat = np.array([1.0, 2.0, np.nan, 4.0])
    out = scores(y, yhat)
    assert out["n"] == 2
    assert out["rmse"] == pytest.approx(np.sqrt(0.5))


def test_constant_measurement_gives_none_not_nan() -> None:
    out = scores(np.ones(5), np.ones(5) * 2)
    assert out["rmse"] == 1.0
    assert out["ndei"] is None and out["vaf"] is None and out["fit"] is None
