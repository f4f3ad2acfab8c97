"""A small synthetic rate table with known noise, for examples, tests and benchmarks.

Three decoupled first-order rate loops with a mild nonlinearity in the command gain,
``ṗ = (g·u·(1 + ½|u|) − p) / τ``, driven by pilot-like stepped commands, integrated with
Euler steps at ``1/rate_hz`` and measured with white gyro noise σ. The table follows the
FlightTable contract (``t`` index, ``p q r``, ``u_roll u_pitch u_yaw u_thrust``,
``segment``) and records σ in ``attrs["noise"]["gyro_std"]`` as the simulator does.

>>> table = rate_table(1000, seed=1)
>>> table.shape, table.attrs["noise"]["gyro_std"]
((1000, 8), 0.01)
"""

from __future__ import annotations

import numpy as np
import pandas as pd

TAU = np.array([0.05, 0.05, 0.15])
"""Time constants of the roll, pitch and yaw rate loops, s."""

GAIN = np.array([4.0, 4.0, 2.0])
"""Steady-state rate per unit command, rad/s."""


def rate_table(n: int = 5000, seed: int = 0, sigma: float = 0.01, rate_hz: float = 250.0,
               segments: int = 2, hold: int = 250) -> pd.DataFrame:
    """Simulated rate data.

    Parameters
    ----------
    n
        Rows.
    seed
        Random seed (commands and noise).
    sigma
        Gyro noise standard deviation, rad/s.
    rate_hz
        Sample rate, Hz.
    segments
        Number of equal contiguous segments (the ``segment`` column), as after gaps.
    hold
        Samples each command step is held.
    """
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    u = np.empty((n, 4))
    smooth = np.ones(25) / 25
    for j in range(3):
        steps = np.repeat(rng.uniform(-0.5, 0.5, n // hold + 1), hold)[:n]
        u[:, j] = steps + 0.1 * np.convolve(rng.normal(size=n), smooth, "same")
    u[:, 3] = 0.5 + 0.05 * np.sin(np.arange(n) * dt)
    x = np.zeros((n, 3))
    for k in range(1, n):
        cmd = u[k - 1, :3]
        x[k] = x[k - 1] + dt * (GAIN * cmd * (1.0 + 0.5 * np.abs(cmd)) - x[k - 1]) / TAU
    y = x + rng.normal(scale=sigma, size=x.shape)
    frame = pd.DataFrame(
        {"p": y[:, 0], "q": y[:, 1], "r": y[:, 2], "u_roll": u[:, 0], "u_pitch": u[:, 1],
         "u_yaw": u[:, 2], "u_thrust": u[:, 3]},
        index=pd.Index(np.arange(n) * dt, name="t"),
    )
    frame["segment"] = (np.arange(n) * segments // max(n, 1)).astype(np.int64)
    frame.attrs = {"source": "synthetic", "format": "sim", "rate_hz": rate_hz,
                   "noise": {"gyro_std": sigma}, "mapping": {}, "warnings": []}
    return frame
