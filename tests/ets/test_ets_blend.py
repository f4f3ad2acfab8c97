"""``blend="interpolate"``: the output of a scheduled model with one antecedent input is
the linear interpolation of the rule outputs between the focal points that enclose s;
learning is the same as with ``blend="firing"``."""

from __future__ import annotations

import numpy as np
import pytest

import etsid.ets.model as model_module
from etsid.ets import ETS


def _flight(n: int = 1500, seed: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """y = g(s) x1 + 0.3 x2 with a gain smooth in s; s dwells at 0.2, 0.5 and 0.9."""
    rng = np.random.default_rng(seed)
    levels = np.array([0.2, 0.9, 0.5])
    s = levels[(np.arange(n) // 100) % 3] + 0.01 * rng.normal(size=n)
    X = rng.normal(size=(n, 2))
    y = (1.0 + 2.0 * s) * X[:, 0] + 0.3 * X[:, 1] + 0.01 * rng.normal(size=n)
    return X, np.c_[y, X[:, 1]], s[:, None]


def _model(blend: str, **kw: object) -> ETS:
    return ETS(radius=0.2, clustering="evq", adaptive_spread=False, forgetting=1.0,
               s_range=[[0.0, 1.0]], blend=blend, **kw)  # type: ignore[arg-type]


def _by_hand(model: ETS, X: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Rule outputs from the consequents in original units, interpolated in numpy."""
    R = model.n_rules
    focal = model.state_["cz"][:R, 0]
    raw = model.consequents_raw()  # (R, n + 1, m)
    outs = np.einsum("tj,rjo->tro", np.c_[np.ones(len(X)), X], raw)
    order = np.argsort(focal)
    f = focal[order]
    s = np.clip(S[:, 0], f[0], f[-1])
    k = np.clip(np.searchsorted(f, s, side="right") - 1, 0, R - 2)
    w = (s - f[k]) / (f[k + 1] - f[k])
    rows = np.arange(len(X))
    return ((1 - w)[:, None] * outs[rows, order[k]] + w[:, None] * outs[rows, order[k + 1]])


def test_interpolated_output_is_the_linear_interpolation_of_the_rule_outputs() -> None:
    X, Y, S = _flight()
    model = _model("interpolate")
    model.run(X[:1200], Y[:1200], S[:1200])
    assert model.n_rules >= 3
    probe = np.linspace(-0.1, 1.1, 241)[:, None]  # beyond the outermost focal points too
    Xp = np.resize(X[1200:], (len(probe), 2))
    np.testing.assert_allclose(model.predict(Xp, probe), _by_hand(model, Xp, probe),
                               rtol=1e-9, atol=1e-9)
    # halfway between two neighbouring focal points: the mean of their rule outputs
    f = np.sort(model.state_["cz"][: model.n_rules, 0])
    mid = np.array([[(f[0] + f[1]) / 2]])
    i0, i1 = (int(np.argmin(np.abs(model.state_["cz"][: model.n_rules, 0] - v)))
              for v in f[:2])
    outs = np.c_[1.0, X[:1]] @ model.consequents_raw()[[i0, i1]]
    np.testing.assert_allclose(model.predict(X[:1], mid)[0], outs.mean(axis=0)[0], atol=1e-12)


def test_learning_is_the_same_and_every_prediction_path_agrees() -> None:
    X, Y, S = _flight()
    fired, interp = _model("firing"), _model("interpolate")
    y_fired = fired.run(X[:1200], Y[:1200], S[:1200])
    y_interp = interp.run(X[:1200], Y[:1200], S[:1200])
    for key in ("cz", "Pi", "Cl", "support"):
        np.testing.assert_array_equal(fired.state_[key], interp.state_[key])
    assert not np.allclose(y_fired[1:], y_interp[1:])  # only the output blend differs
    # the one-step prediction run makes before learning a sample equals predict, predict_one
    # and the reloaded rule base's, bit for bit
    x, y, s = X[1200:1201], Y[1200:1201], S[1200:1201]
    want = interp.predict(x, s)
    np.testing.assert_array_equal(interp.predict_one(x[0], s[0]), want[0])
    loaded = ETS.from_dict(interp.to_dict())
    assert loaded.blend == "interpolate"
    np.testing.assert_array_equal(loaded.predict(x, s), want)
    np.testing.assert_array_equal(interp.run(x, y, s), want)


def test_interpolation_with_many_rules_stays_in_the_rule_major_kernel(monkeypatch) -> None:
    """More than six rules: an interpolating model still learns in ``learn_kernel`` (the
    lane kernel has no interpolation), and its one-step output is interpolated."""

    def no_lanes(*args: object) -> int:
        raise AssertionError("learn_lanes called for an interpolating model")

    monkeypatch.setattr(model_module, "learn_lanes", no_lanes)
    rng = np.random.default_rng(1)
    n = 2000
    s = rng.uniform(0.0, 1.0, size=(n, 1))
    X = rng.normal(size=(n, 2))
    Y = (np.sin(6 * s[:, 0]) * X[:, 0])[:, None]
    model = ETS(radius=0.06, clustering="evq", adaptive_spread=False, forgetting=1.0,
                s_range=[[0.0, 1.0]], blend="interpolate", max_rules=20)
    model.run(X[:1900], Y[:1900], s[:1900])
    assert model.n_rules > 6
    want = model.predict(X[1900:], s[1900:])
    np.testing.assert_allclose(want, _by_hand(model, X[1900:], s[1900:]), rtol=1e-9,
                               atol=1e-9)
    for k in range(1900, 1910):  # the prediction run makes before learning each sample
        now = model.predict(X[k : k + 1], s[k : k + 1])
        np.testing.assert_array_equal(model.run(X[k : k + 1], Y[k : k + 1], s[k : k + 1]), now)


@pytest.mark.parametrize("S", [None, np.zeros((10, 2))], ids=["unscheduled", "two-inputs"])
def test_interpolation_needs_one_antecedent_input(S: np.ndarray | None) -> None:
    X = np.random.default_rng(0).normal(size=(10, 2))
    with pytest.raises(ValueError, match="one antecedent"):
        ETS(blend="interpolate").run(X, X[:, 0], S)
    with pytest.raises(ValueError, match="blend must be one of"):
        ETS(blend="linear").run(X, X[:, 0])
