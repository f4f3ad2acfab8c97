"""clustering="evq" (evolving vector quantisation) and fixed scheduling ranges (s_range)."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.ets import ETS


def _two_regimes(n: int = 2000, seed: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """s dwells near 0.25 and 2.0 in turn, with slow straight transitions of 20 samples;
    y = g(s) x1 with g = 1 below s = 1 and 3 above."""
    rng = np.random.default_rng(seed)
    level = np.where((np.arange(n) // 200) % 2 == 0, 0.25, 2.0)
    s = level.copy()
    for start in range(200, n, 200):  # ramp into each new dwell
        s[start:start + 20] = np.linspace(level[start - 1], level[start], 20)
    s += 0.02 * rng.normal(size=n)
    X = rng.normal(size=(n, 2))
    y = np.where(s < 1.0, 1.0, 3.0) * X[:, 0] + 0.01 * rng.normal(size=n)
    return X, y, s[:, None]


def test_evq_focal_points_are_the_means_of_the_samples_each_rule_won() -> None:
    X, y, S = _two_regimes()
    # fixed spreads, as identify's scheduled model uses (etsid.ident.config)
    model = ETS(radius=0.5, clustering="evq", s_range=[[0.0, 2.5]], max_rules=10,
                adaptive_spread=False)
    model.run(X, y, S)
    R = model.n_rules
    focal = model.state_["cz"][:R, 0]
    # the two dwells each own a rule whose focal point is the dwell's mean height (the
    # ramps move it by their share of the samples it won, a few %)
    low, high = focal.min(), focal.max()
    assert low == pytest.approx(0.25, abs=0.05) and high == pytest.approx(2.0, abs=0.06)
    assert 2 <= R <= 4
    raw = model.consequents_raw()[:, 1, 0]
    assert raw[np.argmin(focal)] == pytest.approx(1.0, abs=0.05)
    assert raw[np.argmax(focal)] == pytest.approx(3.0, abs=0.05)
    # the potentials pull focal points towards the global mean (1.1) instead: no rule of
    # the default clustering sits on the high dwell
    pot = ETS(radius=0.5, s_range=[[0.0, 2.5]], max_rules=10, adaptive_spread=False)
    pot.run(X, y, S)
    assert np.abs(pot.state_["cz"][: pot.n_rules, 0] - 2.0).min() > 0.2


def test_s_range_is_fixed_and_only_for_scheduled_models() -> None:
    X, y, S = _two_regimes(400)
    model = ETS(radius=0.5, clustering="evq", s_range=[[0.0, 5.0]])
    model.run(X, y, S)
    assert model.state_["lo"][0] == 0.0 and model.state_["hi"][0] == 5.0
    assert model.to_dict()["params"]["s_range"] == [[0.0, 5.0]]
    assert ETS.from_dict(model.to_dict()).s_range == [[0.0, 5.0]]
    with pytest.raises(ValueError, match="s_range is for a scheduled model"):
        ETS(s_range=[[0.0, 1.0]]).run(X, y)
    with pytest.raises(ValueError, match="clustering must be one of"):
        ETS(clustering="kmeans").run(X, y, S)


def test_leading_rule_is_the_rule_whose_focal_point_is_nearest() -> None:
    X, y, S = _two_regimes()
    model = ETS(radius=0.5, clustering="evq", s_range=[[0.0, 2.5]], max_rules=10,
                adaptive_spread=False)
    model.run(X, y, S)
    focal = model.state_["cz"][: model.n_rules, 0]
    lead = model.leading_rule(np.array([[0.25], [2.0]]))
    assert lead.tolist() == [int(np.argmin(np.abs(focal - 0.25))),
                             int(np.argmin(np.abs(focal - 2.0)))]
    assert lead[0] != lead[1]
