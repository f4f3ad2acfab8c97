"""The ``ige-oge`` scenario: dwells in and out of ground effect, climbs and descents."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.errors import SimError
from etsid.sim import simulate
from etsid.sim.scenarios import SCENARIOS, regime_profile, resolve_params


def test_profile_dwells_low_and_at_each_high_level_with_consistent_rate() -> None:
    t = np.arange(0.0, 150.0, 0.01)
    alt, rate = regime_profile(t, 0.25, [1.0, 2.5, 1.75], 2.0, 12.0, 3.0)
    assert alt[t < 14.0] == pytest.approx(0.25)
    for level in (1.0, 1.75, 2.5):
        assert np.sum(np.abs(alt - level) < 1e-9) * 0.01 > 10.0  # a dwell of > 10 s
    assert np.sum(np.abs(alt - 0.25) < 1e-9) * 0.01 > 60.0  # half the flight in ground effect
    np.testing.assert_allclose(np.gradient(alt, t)[1:-1], rate[1:-1], atol=5e-3)
    assert SCENARIOS["ige-oge"]["params"]["duration"] >= 120.0


def test_flight_visits_both_regimes_with_rich_excitation() -> None:
    fl = simulate("ige-oge", duration=60.0, seed=4)
    alt = fl.truth["true_alt"].to_numpy()
    t = fl.truth.index.to_numpy()
    assert np.abs(alt[(t > 5) & (t < 13)] - 0.25).max() < 0.06  # in ground effect
    assert np.abs(alt[(t > 20) & (t < 28)] - 1.0).max() < 0.15  # out of it
    ge = fl.truth[[c for c in fl.truth if c.startswith("true_ge")]].to_numpy().mean(axis=1)
    assert ge[(t > 5) & (t < 13)].mean() > 1.1 > 1.04 > ge[(t > 20) & (t < 28)].mean()
    for axis in "pq":
        assert fl.table[axis].std() > 0.1  # rad/s, excited throughout


def test_settings_are_checked() -> None:
    with pytest.raises(SimError, match="high_altitudes"):
        resolve_params("ige-oge", None, {"high_altitudes": [1.0, -2.0]})
    assert resolve_params("ige-oge", None, {"dwell": 5.0})["dwell"] == 5.0
