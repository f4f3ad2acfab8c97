"""Flight scores on responses whose answers are known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from etsid.control.metrics import flight_metrics, settle_band, settling_times


def _table(t: np.ndarray, r: np.ndarray, h: np.ndarray, u: np.ndarray) -> pd.DataFrame:
    return pd.DataFrame({"alt_ref": r, "true_alt": h, "u_thrust": u},
                        index=pd.Index(t, name="t"))


def test_first_order_step_settles_at_tau_ln20() -> None:
    dt, tau, size = 0.001, 0.7, 1.0
    t = np.arange(0.0, 20.0, dt)
    r = np.where(t >= 2.0, 2.0, 1.0)
    h = np.where(t >= 2.0, 2.0 - size * np.exp(-(t - 2.0) / tau), 1.0)
    (st,) = settling_times(t, r, h, [2.0])
    assert settle_band(size) == pytest.approx(0.05)
    assert st == pytest.approx(tau * math.log(20.0), abs=2 * dt)


def test_small_steps_use_the_2cm_floor_and_unsettled_steps_are_none() -> None:
    t = np.arange(0.0, 10.0, 0.01)
    r = np.where(t >= 1.0, 1.1, 1.0)
    h = np.where(t >= 1.0, 1.1 - 0.1 * np.exp(-(t - 1.0)), 1.0)
    (st,) = settling_times(t, r, h, [1.0])
    assert st == pytest.approx(math.log(0.1 / 0.02), abs=0.011)
    h_bad = np.where(t >= 1.0, 1.0, 1.0)
    assert settling_times(t, r, h_bad, [1.0]) == [None]


def test_rmse_max_and_effort_after_10s() -> None:
    dt = 0.02
    t = np.arange(0.0, 30.0, dt)
    r = np.ones_like(t)
    h = np.where(t < 10.0, 0.0, 1.0 - 0.1 * np.sin(2 * np.pi * t))
    u = 0.5 + 0.01 * np.sin(2 * np.pi * 0.5 * t)
    m = flight_metrics(_table(t, r, h, u))
    assert m["tracking_rmse"] == pytest.approx(0.1 / math.sqrt(2), rel=1e-3)
    assert m["max_error"] == pytest.approx(0.1, rel=1e-2)
    assert m["max_error_all"] == pytest.approx(1.0)
    # RMS of d/dt [0.01 sin(pi t)] = 0.01 pi / sqrt(2)
    assert m["control_effort"] == pytest.approx(0.01 * math.pi / math.sqrt(2), rel=1e-2)
    assert m["settling_time"] is None
