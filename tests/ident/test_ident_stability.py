"""Unstable frozen models: the spectral radius of the linearised output recursion
(known answers on constructed linear models), and its flag in the free-run metrics."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from etsid.ident.evaluate import output_metrics, prediction_columns
from etsid.ident.regressors import RegressorSpec, build
from etsid.ident.simulate import linear_stability


class LinearModel:
    """y(k) = θ · x(k): a frozen model with known coefficients."""

    def __init__(self, theta: np.ndarray) -> None:
        self.theta = np.atleast_2d(theta)

    def predict_one(self, x: np.ndarray, s: np.ndarray | None = None) -> np.ndarray:
        return self.theta @ x

    def predict(self, X: np.ndarray, S: np.ndarray | None = None) -> np.ndarray:
        return X @ self.theta.T


def test_first_order_radius_and_doubling_time() -> None:
    spec = RegressorSpec.parse("y[k-1],u[k-1]", ["y"])
    out = linear_stability(LinearModel(np.array([1.05, 0.3])).predict_one, spec,
                           np.array([0.2, -1.0]), rate_hz=50.0)
    assert out["spectral_radius"] == pytest.approx(1.05, rel=1e-6)
    assert out["unstable"]
    assert out["doubling_time_s"] == pytest.approx(np.log(2) / (50 * np.log(1.05)), rel=1e-5)
    assert out["growth_per_s"] == pytest.approx(1.05 ** 50, rel=1e-4)
    stable = linear_stability(LinearModel(np.array([0.9, 0.3])).predict_one, spec,
                              np.zeros(2), 50.0)
    assert stable["spectral_radius"] == pytest.approx(0.9) and not stable["unstable"]
    assert stable["doubling_time_s"] is None


def test_second_order_and_coupled_outputs() -> None:
    # y = 1.5 y1 − 0.7 y2: complex poles of modulus √0.7, stable although 1.5 > 1
    spec = RegressorSpec.parse("y[k-1],y[k-2]", ["y"])
    out = linear_stability(LinearModel(np.array([1.5, -0.7])).predict_one, spec,
                           np.zeros(2), 50.0)
    assert out["spectral_radius"] == pytest.approx(np.sqrt(0.7), rel=1e-6)
    assert not out["unstable"]
    # p = 0.9 p1 + 0.5 q1, q = 0.5 p1 + 0.9 q1: each diagonal stable, eigenvalue 1.4
    spec = RegressorSpec.parse("p[k-1],q[k-1]", ["p", "q"])
    out = linear_stability(LinearModel(np.array([[0.9, 0.5], [0.5, 0.9]])).predict_one, spec,
                           np.zeros(2), 50.0)
    assert out["spectral_radius"] == pytest.approx(1.4, rel=1e-6) and out["unstable"]
    # a nonlinear model is judged by its slope at the operating point
    spec = RegressorSpec.parse("y[k-1]", ["y"])
    out = linear_stability(lambda x: np.array([0.5 * x[0] ** 2]), spec, np.array([1.5]), 50.0)
    assert out["spectral_radius"] == pytest.approx(1.5, rel=1e-6)


def test_unstable_frozen_model_is_flagged_in_metrics() -> None:
    rng = np.random.default_rng(3)
    n = 400
    u = rng.normal(size=n)
    y = np.zeros(n)
    for k in range(1, n):  # the true plant is stable: y = 0.8 y1 + 0.5 u1
        y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1]
    table = pd.DataFrame({"y": y, "u": u}, index=pd.Index(np.arange(n) / 50.0, name="t"))
    spec = RegressorSpec.parse("y[k-1],u[k-1]", ["y"])
    reg = build(table, spec)
    split = 300
    # a frozen model that got the pole wrong (1.02): unstable, drifts slowly
    model = LinearModel(np.array([1.02, 0.5]))
    yhat = np.full((len(reg.Y), 1), np.nan)
    cols, info = prediction_columns(reg, spec, split, len(table), yhat, model, table)
    assert info["stability"]["ets"]["unstable"]
    assert info["stability"]["ets"]["spectral_radius"] == pytest.approx(1.02, rel=1e-6)
    assert not info["stability"]["arx"]["unstable"]  # ARX refits the stable plant
    assert info["stability"]["arx"]["spectral_radius"] == pytest.approx(0.8, abs=1e-6)
    metrics = output_metrics(reg, spec, split, cols, {}, None, info)["y"]
    ets_run, arx_run = metrics["validation"]["free_run"], metrics["arx"]["validation"]["free_run"]
    assert ets_run["unstable_model"] and ets_run["spectral_radius"] == pytest.approx(1.02)
    assert ets_run["doubling_time_s"] == pytest.approx(np.log(2) / (50 * np.log(1.02)), rel=1e-4)
    assert not arx_run["unstable_model"] and arx_run["doubling_time_s"] is None
