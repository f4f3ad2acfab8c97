"""One simulated flight, every log format: ingesting each must give back the simulated signals.

This is what proves the writers' and readers' units, clocks and frame conversions
(FLU/ENU in ROS, FRD/NED in MAVLink) against each other and against the simulator.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.ingest import read_log
from etsid.sim import simulate
from etsid.sim.writers import write_log

FORMATS = ["tlog", "ros1", "ros2-db3", "ros2-mcap", "mcap", "mcap-ros1", "mcap-json"]
SUFFIX = {"tlog": ".tlog", "ros1": ".bag", "ros2-db3": ".db3", "ros2-mcap": "",
          "mcap": ".mcap", "mcap-ros1": ".mcap", "mcap-json": ".mcap"}

# column -> absolute tolerance on the RMS error after alignment (quantisation of the format)
TOLERANCE = {
    "p": 2e-3, "q": 2e-3, "r": 2e-3,
    "roll": 2e-3, "pitch": 2e-3, "yaw": 2e-3,
    "u_roll": 4e-3, "u_pitch": 4e-3, "u_yaw": 4e-3, "u_thrust": 4e-3,
    "ax": 0.05, "ay": 0.05, "az": 0.05,
    "vx": 0.02, "vy": 0.02, "vz": 0.02,
    "alt": 0.01, "vbat": 0.02,
    **{f"m{i}": 4e-3 for i in range(1, 7)},
}


@pytest.fixture(scope="module")
def flight() -> pd.DataFrame:
    return simulate("hover-ige", duration=8.0, seed=3).table


def best_lag(reference: pd.Series, read: pd.Series) -> float:
    """Time shift (s) that best aligns ``read`` onto ``reference`` (clock origins differ)."""
    t_ref, y_ref = reference.index.to_numpy(), reference.to_numpy()
    t, y = read.index.to_numpy(), read.to_numpy()
    lags = np.arange(-1.0, 1.0, 0.001)
    cost = [np.nanmean((np.interp(t + lag, t_ref, y_ref) - y) ** 2) for lag in lags]
    return float(lags[int(np.argmin(cost))])


def window_error(read: pd.Series, t_sim: np.ndarray, y_sim: np.ndarray, period: float,
                 angle: bool) -> np.ndarray:
    """Distance of each read value from the range the simulation spans within ±1.5 native
    periods of it: a held or interpolated sample lies inside that range when units, frames
    and clocks are right."""
    t = read.index.to_numpy()
    y = read.to_numpy()
    lo = np.searchsorted(t_sim, t - 1.5 * period - 0.004)
    hi = np.searchsorted(t_sim, t + 1.5 * period + 0.004)
    err = np.empty(t.size)
    for i, (a, b) in enumerate(zip(lo, hi, strict=True)):
        window = y_sim[a:max(b, a + 1)]
        if angle:
            window = y[i] + np.angle(np.exp(1j * (window - y[i])))
        err[i] = max(window.min() - y[i], y[i] - window.max(), 0.0)
    return err


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_format_gives_back_the_simulated_signals(tmp_path: Path, flight: pd.DataFrame,
                                                       fmt: str) -> None:
    written = write_log(flight, tmp_path / f"flight{SUFFIX[fmt]}", fmt)
    table = read_log(written)
    lag = best_lag(flight["p"], table["p"])
    checked = []
    t_sim = flight.index.to_numpy() - lag
    for column, tol in TOLERANCE.items():
        if column not in table.columns:
            continue
        read = table[column].dropna()
        period = 1.0 / table.attrs["signals"][column]["rate_hz"]
        err = window_error(read, t_sim, flight[column].to_numpy(), period, column == "yaw")
        rms = float(np.sqrt(np.mean(err**2)))
        assert rms < tol, f"{fmt} {column}: rms {rms:.4g} outside the simulated values"
        truth = np.interp(read.index.to_numpy(), t_sim, flight[column].to_numpy())
        if np.std(truth) > 20 * tol and column != "yaw":
            corr = np.corrcoef(truth, read.to_numpy())[0, 1]
            assert corr > 0.9, f"{fmt} {column}: correlation {corr:.3f} (sign or scale?)"
        checked.append(column)
    core = {"p", "q", "r", "roll", "pitch", "yaw", "u_roll", "u_pitch", "u_yaw", "ax", "ay",
            "az", "alt", "vbat"}
    assert core <= set(checked), f"{fmt}: missing {sorted(core - set(checked))}"
