"""Linear ARX baseline on the same regressors as the eTS model.

``y_k = θᵀ [1, x_k]``, fitted by least squares (batch) or by recursive least squares
(online, predict-then-learn: the prediction at k uses only samples before k, exactly as
the eTS online run does).

>>> rng = np.random.default_rng(0)
>>> X = rng.normal(size=(200, 2)); Y = 0.5 + X @ np.array([[2.0], [-1.0]])
>>> model = ARX.fit(X, Y)
>>> np.round(model.theta.ravel(), 6).tolist()
[0.5, 2.0, -1.0]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit


def _extend(X: np.ndarray) -> np.ndarray:
    return np.column_stack([np.ones(X.shape[0]), X])


@dataclass
class ARX:
    """A fitted linear model with intercept.

    Attributes
    ----------
    theta : ndarray, shape (n + 1, m)
        Intercept row first, then one row per regressor; one column per output.
    """

    theta: np.ndarray

    @classmethod
    def fit(cls, X: np.ndarray, Y: np.ndarray) -> ARX:
        """Least-squares fit of ``Y`` (N, m) on ``[1, X]`` (N, n)."""
        Y = np.asarray(Y, dtype=float).reshape(len(Y), -1)
        theta, *_ = np.linalg.lstsq(_extend(np.asarray(X, dtype=float)), Y, rcond=None)
        return cls(theta)

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Predictions (N, m) for regressors ``X`` (N, n)."""
        return _extend(np.asarray(X, dtype=float)) @ self.theta

    def predict_one(self, x: np.ndarray) -> np.ndarray:
        """Prediction (m,) for one regressor vector ``x`` (n,)."""
        return self.theta[0] + np.asarray(x, dtype=float) @ self.theta[1:]


@njit(cache=True)
def _rls_kernel(X: np.ndarray, Y: np.ndarray, omega: float) -> np.ndarray:  # pragma: no cover
    n, m = X.shape[1] + 1, Y.shape[1]
    P = np.eye(n) * omega
    theta = np.zeros((n, m))
    out = np.empty(Y.shape)
    xe = np.empty(n)
    for k in range(X.shape[0]):
        xe[0] = 1.0
        xe[1:] = X[k]
        out[k] = xe @ theta
        Px = P @ xe
        gain = Px / (1.0 + xe @ Px)
        theta += np.outer(gain, Y[k] - out[k])
        P -= np.outer(gain, Px)
        P = 0.5 * (P + P.T)
    return out


def rls_reference(X: np.ndarray, Y: np.ndarray, omega: float = 1e6) -> np.ndarray:
    """Plain-numpy version of :func:`rls_online` (kept for equivalence tests)."""
    n = X.shape[1] + 1
    P = np.eye(n) * omega
    theta = np.zeros((n, Y.shape[1]))
    out = np.empty(Y.shape)
    for k in range(X.shape[0]):
        xe = np.r_[1.0, X[k]]
        out[k] = xe @ theta
        Px = P @ xe
        gain = Px / (1.0 + xe @ Px)
        theta += np.outer(gain, Y[k] - out[k])
        P -= np.outer(gain, Px)
        P = 0.5 * (P + P.T)
    return out


def rls_online(X: np.ndarray, Y: np.ndarray, omega: float = 1e6) -> np.ndarray:
    """Online ARX one-step predictions (N, m), each made before learning from its sample.

    Parameters
    ----------
    X : ndarray, shape (N, n)
        Regressors, in their own units (columns are scaled internally for conditioning).
    Y : ndarray, shape (N, m)
        Outputs.
    omega
        Initial covariance ``Ω·I`` (large: the estimate tracks batch least squares on
        the samples seen so far).

    Notes
    -----
    The first ``n + 1`` predictions (fewer samples than parameters) are NaN, as the eTS
    model's first prediction is: the estimate is not determined yet.
    """
    X = np.asarray(X, dtype=float)
    Y = np.asarray(Y, dtype=float).reshape(len(X), -1)
    scale = np.max(np.abs(X), axis=0) if len(X) else np.ones(X.shape[1])
    scale[~(scale > 0)] = 1.0
    out = _rls_kernel(np.ascontiguousarray(X / scale), np.ascontiguousarray(Y), float(omega))
    out[: X.shape[1] + 1] = np.nan
    return out
