"""identify merges indistinguishable rules at the freeze and at the end: the merges are in
metrics.json ``rules.merges`` and in history.parquet (``merges``, ``events``, ``n_rules``)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from etsid.ident import IdentConfig, identify

BASE = dict(outputs=["y"], regressors="y[k-1],u[k-1]", segments="all", radius=0.3,
            antecedent="alt[k-1]", merge=True)  # generic models do not merge by default


def _table(gain_low: float, gain_high: float, n: int = 3000, seed: int = 0) -> pd.DataFrame:
    """y[k] = 0.6 y[k-1] + g u[k-1] + noise, g = gain_low at 0.25 m, gain_high at 2 m."""
    rng = np.random.default_rng(seed)
    alt = np.where((np.arange(n) // 300) % 2 == 0, 0.25, 2.0) + 0.02 * rng.normal(size=n)
    u = rng.normal(size=n)
    y = np.zeros(n)
    for k in range(1, n):
        g = gain_low if alt[k - 1] < 1.0 else gain_high
        y[k] = 0.6 * y[k - 1] + g * u[k - 1] + 0.3 * rng.normal()
    return pd.DataFrame({"y": y, "u": u, "alt": alt},
                        index=pd.Index(np.arange(n) * 0.02, name="t"))


def test_one_physics_at_two_heights_ends_with_one_rule_and_the_merges_in_history() -> None:
    run = identify(_table(1.5, 1.5), IdentConfig(**BASE))
    merges = run.metrics["rules"]["merges"]
    assert run.metrics["rules"]["peak"] >= 2 and merges
    assert run.metrics["rules"]["frozen"] == 1
    hist = run.history
    assert int(hist["merges"].sum()) == len(merges)
    assert hist["events"].str.contains("merge").sum() >= 1
    assert int(hist["n_rules"].iloc[-1]) == run.metrics["rules"]["final"]
    kept = identify(_table(2.0, 1.0), IdentConfig(**BASE))
    assert kept.metrics["rules"]["frozen"] >= 2  # different gains: not merged
    unmerged = identify(_table(1.5, 1.5), IdentConfig(**{**BASE, "merge": None}))
    assert unmerged.metrics["rules"]["frozen"] >= 2 and not unmerged.metrics["rules"]["merges"]
