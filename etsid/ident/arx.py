"""Linear ARX baseline on the same regressors as the eTS model.

``y_k = θᵀ [1, x_k]``, fitted two ways:

* **batch** (:meth:`ARX.fit`, the validation baseline): regularised least squares on the
  learning part. Each regressor is standardised (mean and standard deviation of the
  learning part), the ridge penalty ``λ N ‖β‖²`` with λ = :data:`RIDGE` is added to the
  normal equations (the intercept is not penalised), and the coefficients are mapped back
  to the original units. λ is small enough not to bias a well-posed fit (Box–Jenkins and
  the simulated flights give the plain least-squares numbers to 3 digits) and keeps the
  solution bounded when regressors are collinear — still hover, where the lagged rates and
  held commands barely move.
* **online** (:func:`rls_online`, predict-then-learn: the prediction at k uses only
  samples before k, exactly as the eTS online run does): recursive least squares on the
  standardised regressors, started from θ = 0 and P = Ω·I with Ω = :data:`RLS_OMEGA`, i.e.
  a ridge prior of weight 1/Ω per standardised coefficient. The old start (Ω = 10⁶ on
  raw-scaled regressors) made the first updates on nearly collinear still-hover data
  explode.

>>> rng = np.random.default_rng(0)
>>> X = rng.normal(size=(200, 2)); Y = 0.5 + X @ np.array([[2.0], [-1.0]])
>>> model = ARX.fit(X, Y, ridge=0.0)
>>> np.round(model.theta.ravel(), 6).tolist()
[0.5, 2.0, -1.0]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

RIDGE = 1e-6
"""Ridge weight of the batch fit, per sample and standardised regressor."""

RLS_OMEGA = 1e3
"""Initial covariance of online RLS on standardised regressors (prior weight 1/Ω)."""


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
    def fit(cls, X: np.ndarray, Y: np.ndarray, ridge: float = RIDGE) -> ARX:
        """Regularised least-squares fit of ``Y`` (N, m) on ``[1, X]`` (N, n) (module
        docstring); ``ridge=0`` is plain least squares."""
        X = np.asarray(X, dtype=float)
        Y = np.asarray(Y, dtype=float).reshape(len(Y), -1)
        mean = X.mean(axis=0)
        centred = X - mean
        # X.std(axis=0) from the centred columns it would compute again (numpy's _var:
        # Σ d² / N, then √; the same bits, tests/ident/test_ident_arx.py)
        std = np.sqrt((centred * centred).sum(axis=0) / len(X))
        live = std > 0
        if live.all():  # the same numbers without the column selection's copies
            Z = centred / std
        else:
            Z = np.zeros_like(X)
            Z[:, live] = (X[:, live] - mean[live]) / std[live]
        y_mean = Y.mean(axis=0)
        gram = Z.T @ Z + ridge * len(X) * np.eye(X.shape[1])
        gram[~live, ~live] = 1.0
        beta = np.linalg.lstsq(gram, Z.T @ (Y - y_mean), rcond=None)[0]
        beta[~live] = 0.0
        coef = np.zeros_like(beta)
        coef[live] = beta[live] / std[live, None]
        theta = np.vstack([y_mean - mean @ coef, coef])
        return cls(theta)

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Predictions (N, m) for regressors ``X`` (N, n)."""
        return _extend(np.asarray(X, dtype=float)) @ self.theta

    def predict_one(self, x: np.ndarray) -> np.ndarray:
        """Prediction (m,) for one regressor vector ``x`` (n,)."""
        return self.theta[0] + np.asarray(x, dtype=float) @ self.theta[1:]


@njit(cache=True, boundscheck=False)
def _rls_kernel(X: np.ndarray, Y: np.ndarray, omega: float) -> np.ndarray:  # pragma: no cover
    """Predict-then-learn RLS over the rows of ``X``, without allocating per sample: the
    updates of :func:`rls_reference` element by element, with the same result bit for bit
    (the symmetrisation keeps P[a, b] and P[b, a] equal, which lets P x_e be summed by
    columns and the update and its symmetrisation be one pass along the rows)."""
    n, m = X.shape[1] + 1, Y.shape[1]
    P = np.eye(n) * omega
    theta = np.zeros((n, m))
    out = np.empty(Y.shape)
    xe = np.empty(n)
    px = np.empty(n)
    gain = np.empty(n)
    err = np.empty(m)
    for k in range(X.shape[0]):
        xe[0] = 1.0
        for a in range(1, n):
            xe[a] = X[k, a - 1]
        for o in range(m):
            acc = 0.0
            for a in range(n):
                acc += xe[a] * theta[a, o]
            out[k, o] = acc
            err[o] = Y[k, o] - acc
        # px = P x_e as a sum of columns, as etsid.ets.kernels._gain_by_columns does (P is
        # exactly symmetric: each px[a] is summed in the row dot product's order), so the
        # inner loop runs along a row and vectorises
        for a in range(n):
            px[a] = 0.0
        for b in range(n):
            xb = xe[b]
            for a in range(n):
                px[a] += P[b, a] * xb
        den = 0.0
        for a in range(n):
            den += xe[a] * px[a]
        den += 1.0
        for a in range(n):
            gain[a] = px[a] / den
            for o in range(m):
                theta[a, o] += gain[a] * err[o]
        # P - gain pxᵀ symmetrised, in one pass along the rows: the mean of the (a, b) and
        # (b, a) updates (P[a, b] = P[b, a] before), which is the update itself on the
        # diagonal and exactly symmetric off it
        for a in range(n):
            ga = gain[a]
            pa = px[a]
            for b in range(n):
                p_ab = P[a, b]
                P[a, b] = 0.5 * ((p_ab - ga * px[b]) + (p_ab - gain[b] * pa))
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


def rls_online(X: np.ndarray, Y: np.ndarray, omega: float = RLS_OMEGA) -> np.ndarray:
    """Online ARX one-step predictions (N, m), each made before learning from its sample.

    Parameters
    ----------
    X : ndarray, shape (N, n)
        Regressors, in their own units (standardised internally with each column's mean
        and standard deviation over ``X``, as ``--normalise learn`` uses fixed ranges).
    Y : ndarray, shape (N, m)
        Outputs.
    omega
        Initial covariance ``Ω·I`` on the standardised regressors: the estimate is ridge
        regression with weight 1/Ω on the samples seen so far.

    Notes
    -----
    The first ``n + 1`` predictions (fewer samples than parameters) are NaN, as the eTS
    model's first prediction is: the estimate is not determined yet.
    """
    X = np.asarray(X, dtype=float)
    Y = np.asarray(Y, dtype=float).reshape(len(X), -1)
    mean = X.mean(axis=0) if len(X) else np.zeros(X.shape[1])
    scale = X.std(axis=0) if len(X) else np.ones(X.shape[1])
    scale[~(scale > 0)] = 1.0
    out = _rls_kernel(np.ascontiguousarray((X - mean) / scale), np.ascontiguousarray(Y),
                      float(omega))
    out[: X.shape[1] + 1] = np.nan
    return out
