"""identify warns when a log is too slow or too short to identify rate dynamics from."""

from __future__ import annotations

import numpy as np
import pandas as pd

from etsid.ident.checks import data_warnings


def table(rate_hz: float, seconds: float) -> pd.DataFrame:
    t = np.arange(0.0, seconds, 1.0 / rate_hz)
    return pd.DataFrame({"p": np.sin(t)}, index=pd.Index(t, name="t"))


def test_slow_telemetry_is_flagged_for_the_rate_model_only() -> None:
    slow = table(4.0, 200.0)
    assert any("4 Hz" in w for w in data_warnings(slow, 800, 5, rate_model=True))
    assert data_warnings(slow, 800, 5, rate_model=False) == []
    assert data_warnings(table(50.0, 20.0), 1000, 5, rate_model=True) == []


def test_short_log_is_flagged_by_samples_per_parameter() -> None:
    fast = table(50.0, 2.0)
    notes = data_warnings(fast, 99, 36, rate_model=True)
    assert len(notes) == 1 and "99 usable samples for 37 parameters" in notes[0]
    assert data_warnings(fast, 370, 36, rate_model=True) == []
