"""A two-regime SISO flight with a known gain at each height, for the rule tests."""

from __future__ import annotations

import numpy as np
import pandas as pd


def two_regime_table(gain_low: float, gain_high: float, n: int = 3000, seed: int = 0,
                     rotor_radius_m: float | None = None) -> pd.DataFrame:
    """y[k] = 0.6 y[k-1] + g u[k-1] + noise, g = gain_low at 0.25 m, gain_high at 2 m
    (6 s dwells at 50 Hz); ``rotor_radius_m`` goes into the provenance when given."""
    rng = np.random.default_rng(seed)
    alt = np.where((np.arange(n) // 300) % 2 == 0, 0.25, 2.0) + 0.02 * rng.normal(size=n)
    u = rng.normal(size=n)
    y = np.zeros(n)
    for k in range(1, n):
        g = gain_low if alt[k - 1] < 1.0 else gain_high
        y[k] = 0.6 * y[k - 1] + g * u[k - 1] + 0.3 * rng.normal()
    table = pd.DataFrame({"y": y, "u": u, "alt": alt},
                         index=pd.Index(np.arange(n) * 0.02, name="t"))
    if rotor_radius_m is not None:
        table.attrs["rotor_radius_m"] = rotor_radius_m
    return table
