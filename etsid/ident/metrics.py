"""Prediction-quality metrics: RMSE, NDEI, VAF and fit % (NRMSE as MATLAB's ``compare``).

All functions ignore rows where the measurement or the prediction is NaN.

>>> y = np.array([1.0, 2.0, 3.0, 4.0]); yhat = np.array([1.1, 1.9, 3.1, 3.9])
>>> round(rmse(y, yhat), 6)
0.1
>>> round(fit_percent(y, yhat), 2)
91.06
"""

from __future__ import annotations

import numpy as np

__all__ = ["fit_percent", "ndei", "rmse", "scores", "vaf"]


def _pair(y: np.ndarray, yhat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(y, dtype=float).ravel()
    yhat = np.asarray(yhat, dtype=float).ravel()
    if y.shape != yhat.shape:
        raise ValueError(f"measured and predicted differ in length: {y.size} vs {yhat.size}")
    keep = np.isfinite(y) & np.isfinite(yhat)
    return y[keep], yhat[keep]


def rmse(y: np.ndarray, yhat: np.ndarray) -> float:
    """Root-mean-square error, in the unit of ``y`` (NaN when no pair is finite)."""
    y, yhat = _pair(y, yhat)
    return float(np.sqrt(np.mean((y - yhat) ** 2))) if y.size else float("nan")


def ndei(y: np.ndarray, yhat: np.ndarray) -> float:
    """Non-dimensional error index: RMSE divided by the standard deviation of ``y``."""
    y, yhat = _pair(y, yhat)
    if y.size == 0:
        return float("nan")
    std = float(np.std(y))
    return float(np.sqrt(np.mean((y - yhat) ** 2)) / std) if std > 0 else float("nan")


def vaf(y: np.ndarray, yhat: np.ndarray) -> float:
    """Variance accounted for, %: ``100 (1 − var(y − ŷ) / var(y))``."""
    y, yhat = _pair(y, yhat)
    if y.size == 0:
        return float("nan")
    var = float(np.var(y))
    return float(100.0 * (1.0 - np.var(y - yhat) / var)) if var > 0 else float("nan")


def fit_percent(y: np.ndarray, yhat: np.ndarray) -> float:
    """Normalised fit, % (MATLAB ``compare``): ``100 (1 − ‖y − ŷ‖ / ‖y − mean(y)‖)``."""
    y, yhat = _pair(y, yhat)
    if y.size == 0:
        return float("nan")
    den = float(np.linalg.norm(y - y.mean()))
    return float(100.0 * (1.0 - np.linalg.norm(y - yhat) / den)) if den > 0 else float("nan")


def scores(y: np.ndarray, yhat: np.ndarray) -> dict[str, float | int | None]:
    """All metrics as a JSON-ready dict: ``rmse`` (unit of y), ``ndei``, ``vaf`` (%),
    ``fit`` (%) and ``n`` (pairs used). NaN becomes ``None``.

    The four metrics of :func:`rmse` … :func:`fit_percent` with their shared terms (the
    finite pairs, the error, its mean square, var(y)) computed once: the same operations
    on the same arrays, so the same numbers."""
    y, yhat = _pair(y, yhat)
    out: dict[str, float | int | None]
    if y.size == 0:
        out = {"rmse": None, "ndei": None, "vaf": None, "fit": None}
    else:
        e = y - yhat
        ms = np.mean(e ** 2)
        var_y = np.var(y)  # np.std(y) is its square root
        std = float(np.sqrt(var_y))
        var = float(var_y)
        den = float(np.linalg.norm(y - y.mean()))
        values = {"rmse": float(np.sqrt(ms)),
                  "ndei": float(np.sqrt(ms) / std) if std > 0 else float("nan"),
                  "vaf": float(100.0 * (1.0 - np.var(e) / var)) if var > 0 else float("nan"),
                  "fit": float(100.0 * (1.0 - np.linalg.norm(e) / den)) if den > 0
                  else float("nan")}
        out = {k: (None if not np.isfinite(v) else float(v)) for k, v in values.items()}
    out["n"] = int(y.size)
    return out
