"""Robust least squares, HAC and jackknife errors on systems with known answers."""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from etsid.fit.regress import Moments, block_ids, correlation_time, robust_lstsq


def _ar1(rng: np.random.Generator, n: int, phi: float) -> np.ndarray:
    return lfilter([1.0], [1.0, -phi], rng.normal(size=n))


def test_correlation_time_of_ar1_is_close_to_its_theory() -> None:
    rng = np.random.default_rng(0)
    phi = 0.8
    tau = correlation_time(_ar1(rng, 40000, phi))
    assert abs(tau - (1 + phi) / (1 - phi)) / ((1 + phi) / (1 - phi)) < 0.25


def test_hac_interval_covers_under_coloured_noise_where_ols_would_not() -> None:
    """Regressor and noise both AR(1) (phi 0.9): the OLS se is ~3x too small; the HAC
    interval must cover the truth about 95 % of the time."""
    hits, ols_hits, n_rep = 0, 0, 60
    for seed in range(n_rep):
        rng = np.random.default_rng(seed)
        x = _ar1(rng, 3000, 0.9)
        y = 2.0 * x + _ar1(rng, 3000, 0.9)
        fit = robust_lstsq(np.column_stack([x, np.ones_like(x)]), y)
        hits += abs(fit.coef[0] - 2.0) <= 1.96 * fit.se[0]
        r = fit.resid
        ols_se = np.sqrt(r @ r / (len(r) - 2) / np.sum((x - x.mean()) ** 2))
        ols_hits += abs(fit.coef[0] - 2.0) <= 1.96 * ols_se
    assert hits / n_rep >= 0.85
    assert ols_hits / n_rep < 0.8


def test_huber_fit_ignores_a_few_gross_outliers() -> None:
    rng = np.random.default_rng(1)
    x = rng.normal(size=2000)
    y = 3.0 * x + 0.1 * rng.normal(size=2000)
    y[::100] += 50.0
    fit = robust_lstsq(np.column_stack([x, np.ones_like(x)]), y)
    assert abs(fit.coef[0] - 3.0) < 0.02


def test_moments_leave_one_block_out_equals_a_refit() -> None:
    rng = np.random.default_rng(2)
    x = np.column_stack([rng.normal(size=1000), np.ones(1000)])
    y = x @ np.array([1.5, -0.3]) + rng.normal(size=1000)
    ids = block_ids(1000)
    m = Moments.of(x, y, ids, 10)
    beta, ssr = m.solve(3)
    keep = ids != 3
    ref = np.linalg.lstsq(x[keep], y[keep], rcond=None)[0]
    assert np.allclose(beta, ref, atol=1e-10)
    assert np.isclose(ssr, np.sum((y[keep] - x[keep] @ ref) ** 2))
