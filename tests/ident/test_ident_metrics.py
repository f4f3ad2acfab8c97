"""Metrics against hand-computed values."""

from __future__ import annotations

import warnings

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


def test_scores_equal_the_four_metrics_exactly() -> None:
    rng = np.random.default_rng(5)
    for trial in range(300):
        y = rng.normal(size=int(rng.integers(0, 80))) * 10.0 ** int(rng.integers(-3, 4))
        yhat = y + rng.normal(size=y.size) * (0.0 if trial % 9 == 0 else 0.1)
        if trial % 4 == 0:
            y[rng.random(y.size) < 0.3] = np.nan
        if trial % 6 == 0:
            y[:] = 2.0  # no spread: ndei, vaf and fit are undefined
        got = scores(y, yhat)
        want = {"rmse": rmse(y, yhat), "ndei": ndei(y, yhat), "vaf": vaf(y, yhat),
                "fit": fit_percent(y, yhat)}
        for key, value in want.items():
            assert got[key] == (value if np.isfinite(value) else None), (trial, key)
        assert got["n"] == int(np.count_nonzero(np.isfinite(y) & np.isfinite(yhat)))


def test_column_bounds_equal_numpy() -> None:
    from etsid.ident.column_bounds import column_bounds

    rng = np.random.default_rng(6)
    for trial in range(200):
        A = rng.normal(size=(int(rng.integers(1, 60)), int(rng.integers(1, 40))))
        if trial % 3 == 0:
            A[rng.random(A.shape) < 0.2] = np.nan
        if trial % 5 == 0:
            A[rng.random(A.shape) < 0.05] = np.inf
        if trial % 7 == 0:
            A[:, 0] = np.nan  # a column without a value: NaN bounds
        lo, hi, finite = column_bounds(A)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # the all-NaN column
            np.testing.assert_array_equal(lo, np.nanmin(A, axis=0))
            np.testing.assert_array_equal(hi, np.nanmax(A, axis=0))
        assert finite == bool(np.isfinite(A).all())
