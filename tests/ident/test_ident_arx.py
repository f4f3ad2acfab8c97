"""ARX baseline: batch least squares and the online RLS kernel."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.ident.arx import ARX, rls_online, rls_reference


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
    scale = np.abs(X).max(axis=0)
    ref = rls_reference(X / scale, Y)
    online = rls_online(X, Y)
    assert np.isnan(online[:4]).all()
    assert np.abs(online[4:] - ref[4:]).max() < 1e-9


def test_online_prediction_uses_only_the_past() -> None:
    X, Y = _data(300)
    online = rls_online(X, Y, omega=1e8)
    k = 250
    batch = ARX.fit(X[:k], Y[:k]).predict(X[k:k + 1])[0]
    assert online[k] == pytest.approx(batch, abs=1e-4)
    assert np.isnan(online[3]).all() and np.isfinite(online[4]).all()
