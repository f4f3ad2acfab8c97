"""ARX baseline: batch least squares and the online RLS kernel."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.ident.arx import ARX, RLS_OMEGA, rls_online, rls_reference


def _data(n: int = 400, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, 3)) * np.array([1.0, 50.0, 0.01])
    Y = np.column_stack([0.3 + X @ np.array([1.0, 0.02, 40.0]),
                         -1.0 + X @ np.array([0.0, -0.01, 5.0])])
    return X, Y + rng.normal(scale=0.01, size=Y.shape)


def test_least_squares_recovers_the_coefficients() -> None:
    X, Y = _data()
    theta = ARX.fit(X, Y).theta
    assert theta[:, 0] == pytest.approx([0.3, 1.0, 0.02, 40.0], rel=5e-3, abs=0.02)
    assert theta[:, 1] == pytest.approx([-1.0, 0.0, -0.01, 5.0], rel=5e-3, abs=0.02)
    model = ARX(theta)
    assert model.predict_one(X[5]) == pytest.approx(model.predict(X[5:6])[0])


def test_rls_kernel_matches_numpy_reference() -> None:
    X, Y = _data(200)
    ref = rls_reference((X - X.mean(axis=0)) / X.std(axis=0), Y, omega=RLS_OMEGA)
    online = rls_online(X, Y)
    assert np.isnan(online[:4]).all()
    assert np.abs(online[4:] - ref[4:]).max() < 1e-9


def test_online_prediction_uses_only_the_past() -> None:
    X, Y = _data(300)
    online = rls_online(X, Y, omega=1e8)
    k = 250
    batch = ARX.fit(X[:k], Y[:k], ridge=0.0).predict(X[k:k + 1])[0]
    assert online[k] == pytest.approx(batch, abs=1e-4)
    assert np.isnan(online[3]).all() and np.isfinite(online[4]).all()


def test_batch_fit_stays_bounded_on_collinear_regressors() -> None:
    # still hover: two regressors that are the same signal up to 1e-9 (plain least squares
    # splits a large coefficient between them); the regularised fit shares it evenly
    rng = np.random.default_rng(3)
    a = rng.normal(size=400)
    X = np.column_stack([a, a + 1e-9 * rng.normal(size=400)])
    Y = (2.0 * a + 0.01 * rng.normal(size=400))[:, None]
    theta = ARX.fit(X, Y).theta
    assert np.abs(theta[1:, 0]).max() < 1.5
    assert theta[1, 0] + theta[2, 0] == pytest.approx(2.0, abs=0.01)


def test_online_rls_does_not_blow_up_on_still_data() -> None:
    # long still stretch (noise only), then excitation: the start must not spike
    rng = np.random.default_rng(4)
    u = np.r_[1e-4 * rng.normal(size=500), rng.normal(size=500)]
    y = np.zeros(1000)
    for k in range(1, 1000):
        y[k] = 0.9 * y[k - 1] + 0.5 * u[k - 1] + 1e-3 * rng.normal()
    X = np.column_stack([np.r_[0, y[:-1]], np.r_[0, u[:-1]]])
    online = rls_online(X, y[:, None])[:, 0]
    assert np.nanmax(np.abs(online)) < 2 * np.abs(y).max()


def _fit_as_before(X: np.ndarray, Y: np.ndarray, ridge: float) -> np.ndarray:
    """ARX.fit's least squares written with numpy's own std and column selection."""
    mean, std = X.mean(axis=0), X.std(axis=0)
    live = std > 0
    Z = np.zeros_like(X)
    Z[:, live] = (X[:, live] - mean[live]) / std[live]
    y_mean = Y.mean(axis=0)
    gram = Z.T @ Z + ridge * len(X) * np.eye(X.shape[1])
    gram[~live, ~live] = 1.0
    beta = np.linalg.lstsq(gram, Z.T @ (Y - y_mean), rcond=None)[0]
    beta[~live] = 0.0
    coef = np.zeros_like(beta)
    coef[live] = beta[live] / std[live, None]
    return np.vstack([y_mean - mean @ coef, coef])


def test_fit_has_the_bits_of_numpys_std() -> None:
    from etsid.ident.arx import RIDGE

    rng = np.random.default_rng(8)
    for trial in range(40):
        n, m = int(rng.integers(50, 2000)), int(rng.integers(1, 40))
        X = rng.normal(size=(n, m)) * 10.0 ** rng.integers(-4, 4, size=m) + rng.normal(size=m)
        if trial % 4 == 0:
            X[:, 0] = 2.5  # a constant column: not live
        Y = X[:, :1] * 0.3 + rng.normal(size=(n, 2))
        np.testing.assert_array_equal(ARX.fit(X, Y).theta, _fit_as_before(X, Y, RIDGE))
