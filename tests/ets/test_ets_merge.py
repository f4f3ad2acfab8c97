"""Rule merging (etsid.ets.merge): neighbouring rules whose consequents are statistically
indistinguishable become one; rules whose local models differ stay apart."""

from __future__ import annotations

import numpy as np

from etsid.ets import ETS
from etsid.ets.merge import merge_rules


def _data(gain_low: float, gain_high: float, n: int = 4000, seed: int = 0):
    """y = 0.6 x1 + g x2 + noise, g by the scheduling variable s (dwells at 4 and 0.5)."""
    rng = np.random.default_rng(seed)
    s = np.where((np.arange(n) // 400) % 2 == 0, 4.0, 0.5) + 0.05 * rng.normal(size=n)
    X = rng.normal(size=(n, 2))
    g = np.where(s > 2.0, gain_low, gain_high)
    Y = 0.6 * X[:, 0] + g * X[:, 1] + 0.1 * rng.normal(size=n)
    return X, Y[:, None], s[:, None]


def _model() -> ETS:
    return ETS(radius=0.3, clustering="evq", adaptive_spread=False, s_range=[[0.0, 5.0]])


def test_one_physics_two_rules_merge_into_one_with_a_merge_event() -> None:
    X, Y, S = _data(1.0, 1.0)
    model = _model()
    model.run(X, Y, S)
    assert model.n_rules >= 2
    before = model.n_rules
    parts = model.consequents_raw()[:, 1:, 0]
    merges = merge_rules(model, X, Y, S)
    assert model.n_rules == 1 and len(merges) == before - 1
    events = [e for e in model.history.events if e["kind"] == "merge"]
    assert [e["rule_id"] for e in events] == [m["absorbed"] for m in merges]
    # the merged consequent combines the two estimates (each weighted by its information)
    cons = model.consequents_raw()[0, 1:, 0]
    assert np.all(cons >= parts.min(axis=0) - 1e-9) and np.all(cons <= parts.max(axis=0) + 1e-9)
    np.testing.assert_allclose(cons, [0.6, 1.0], atol=0.05)
    # and the model keeps learning from the merged state
    model.run(X[:100], Y[:100], S[:100])


def test_different_local_models_stay_apart() -> None:
    X, Y, S = _data(2.0, 1.0)
    model = _model()
    model.run(X, Y, S)
    rules = model.n_rules
    assert merge_rules(model, X, Y, S) == [] or model.n_rules >= 2
    focal = sorted(model.export_state().focal_points[:, 0])
    assert model.n_rules >= 2 and focal[0] < 1.0 and focal[-1] > 3.5
    assert rules >= model.n_rules


def test_a_rule_without_enough_samples_is_absorbed() -> None:
    X, Y, S = _data(2.0, 1.0)
    S = S.copy()
    S[-3:] = 2.3  # three last samples in between: a rule is born there
    model = _model()
    model.run(X, Y, S)
    mids = [f for f in model.export_state().focal_points[:, 0] if 1.5 < f < 3.0]
    assert mids, "the stray samples made no rule"
    merge_rules(model, X, Y, S)
    assert not [f for f in model.export_state().focal_points[:, 0] if 1.9 < f < 2.7]
    assert model.n_rules >= 2
