"""Scheduled eTS: antecedents on a scheduling vector S, consequents on the full X."""

from __future__ import annotations

import json

import numpy as np
import pytest

from etsid.errors import ModelError
from etsid.ets import ETS
from etsid.ets.reference import ReferenceETS


def _regimes(n_samples: int = 2000, seed: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """y = g(s) (x1 - 0.5 x2) + noise with a gain that steps from 1 (s < 0.5) to 2 (s > 1.5);
    s dwells in each regime and moves slowly between them."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_samples)
    s = np.where((t // 250) % 2 == 0, 0.25, 2.0) + 0.05 * rng.normal(size=n_samples)
    X = rng.normal(size=(n_samples, 3))
    gain = np.where(s < 1.0, 1.0, 2.0)
    y = gain * (X[:, 0] - 0.5 * X[:, 1]) + 0.01 * rng.normal(size=n_samples)
    S = np.c_[s, 0.2 * rng.normal(size=n_samples)]
    return X, y, S


CONFIGS = [
    dict(variant="ets"),
    dict(variant="ets+"),
    dict(variant="ets+", rls="global"),
    dict(variant="ets+", adaptive_spread=True, forgetting=0.98),
    dict(variant="ets+", coverage=True, max_rules=4),
    dict(variant="ets+", clustering="evq"),
    dict(variant="ets", clustering="evq", max_rules=3),
    dict(variant="ets+", clustering="evq", adaptive_spread=True, rls="global"),
    dict(variant="ets+", clustering="evq", shared_outputs=(1,)),
    dict(variant="ets+", shared_outputs=(0,), forgetting=0.98, adaptive_spread=True),
]


@pytest.mark.parametrize("cfg", CONFIGS, ids=lambda c: "-".join(str(v) for v in c.values()))
def test_scheduled_kernels_equal_numpy_reference(cfg: dict) -> None:
    X, y, S = _regimes(500, seed=3)
    Y = np.c_[y, X[:, 2] ** 2]
    kw = dict(omega=1000.0, utility_threshold=0.1, min_support=3, prune_after=30) | cfg
    kw.setdefault("max_rules", 8)
    model = ETS(radius=0.3, history_every=41, **kw)
    Yhat = model.run(X, Y, S)
    ref = ReferenceETS(3, 2, np.full(2, 0.3), na=2, **kw)
    Yref = ref.run(X, Y, S)
    np.testing.assert_allclose(Yhat[1:], Yref[1:], rtol=1e-9, atol=1e-9)
    assert [(e["step"], e["kind"], e["rule_id"]) for e in model.history.events] == ref.events
    R = model.n_rules
    want = ref.state()
    np.testing.assert_allclose(model.state_["Pi"][:R], want["Pi"], rtol=1e-9, atol=1e-8)
    np.testing.assert_allclose(model.state_["cz"][:R], want["cz"], rtol=0, atol=0)
    np.testing.assert_allclose(model.state_["rad"][:R], want["rad"], rtol=1e-9)
    np.testing.assert_allclose(model.history.potential, np.array(ref.history)[:, 1], rtol=1e-9)
    assert model.state_["rad"].shape[1] == 2


def test_rules_fire_on_the_scheduling_regimes_and_learn_each_gain() -> None:
    X, y, S = _regimes()
    model = ETS(radius=0.4)
    model.run(X[:1500], y[:1500], S[:1500])
    focal_s = model.state_["cz"][: model.n_rules, 0]
    # a rule in each regime, and the consequents there recover the regime's gain on x1
    assert focal_s.min() < 0.5 and focal_s.max() > 1.5
    raw = model.consequents_raw()[:, 1, 0]
    assert raw[np.argmin(focal_s)] == pytest.approx(1.0, abs=0.1)
    assert raw[np.argmax(focal_s)] == pytest.approx(2.0, abs=0.1)
    sched = model.predict(X[1500:], S[1500:])
    flat = ETS(radius=0.4)
    flat.run(X[:1500], y[:1500])
    rmse_s = np.sqrt(np.mean((sched - y[1500:]) ** 2))
    rmse_f = np.sqrt(np.mean((flat.predict(X[1500:]) - y[1500:]) ** 2))
    assert rmse_s < 0.5 * rmse_f


def test_learn_one_and_predict_one_take_s() -> None:
    X, y, S = _regimes(300)
    a, b = ETS(radius=0.3), ETS(radius=0.3)
    a.run(X, y, S)
    for x_, y_, s_ in zip(X, y, S, strict=True):
        b.learn_one(x_, y_, s_)
    np.testing.assert_array_equal(a.predict(X[:20], S[:20]), b.predict(X[:20], S[:20])[:, 0])
    assert a.predict_one(X[5], S[5])[0] == a.predict(X[5:6], S[5:6])[0]


def test_s_must_match_how_the_model_was_learned() -> None:
    X, y, S = _regimes(200)
    model = ETS()
    model.run(X, y, S)
    with pytest.raises(ValueError, match="pass S"):
        model.predict(X)
    with pytest.raises(ValueError, match="S has"):
        model.predict(X[:5], S[:4])
    with pytest.raises(ValueError, match="S must have 2 columns"):
        model.predict(X[:5], S[:5, :1])
    flat = ETS()
    flat.run(X, y)
    with pytest.raises(ValueError, match="without S"):
        flat.predict(X, S)


def test_scheduled_json_round_trip_is_bit_identical_and_names_antecedents(tmp_path) -> None:
    X, y, S = _regimes(800)
    model = ETS(radius=0.4, input_names=["a", "b", "c"], output_names=["p"],
                antecedent_names=["alt", "thr"])
    model.run(X[:500], y[:500], S[:500])
    path = tmp_path / "rules.json"
    model.save(path)
    raw = json.loads(path.read_text())
    assert raw["schema"] == "etsid.rules/2"
    assert raw["antecedents"] == {"scheduled": True, "names": ["alt", "thr"], "dimension": 2}
    loaded = ETS.load(path)
    np.testing.assert_array_equal(loaded.predict(X[500:], S[500:]), model.predict(X[500:], S[500:]))
    np.testing.assert_array_equal(loaded.run(X[500:], y[500:], S[500:]),
                                  model.run(X[500:], y[500:], S[500:]))
    text = model.rules()
    assert "IF alt ≈" in text and "AND thr ≈" in text and "IF a ≈" not in text
    assert "THEN p = " in text and "·c" in text


def test_version_1_rule_base_still_loads(tmp_path) -> None:
    X, y, _ = _regimes(400)
    model = ETS(radius=0.3)
    model.run(X, y)
    data = model.to_dict()
    assert data["antecedents"] == {"scheduled": False, "names": ["x1", "x2", "x3"],
                                   "dimension": 3}
    v1 = {k: v for k, v in data.items() if k != "antecedents"} | {"schema": "etsid.rules/1"}
    path = tmp_path / "v1.json"
    path.write_text(json.dumps(v1))
    loaded = ETS.load(path)
    np.testing.assert_array_equal(loaded.predict(X), model.predict(X))
    # version 2 requires the antecedents, version 1 forbids them
    with pytest.raises(ModelError, match="antecedents"):
        ETS.from_dict({k: v for k, v in data.items() if k != "antecedents"})
    with pytest.raises(ModelError, match="rule base"):
        ETS.from_dict(v1 | {"antecedents": data["antecedents"]})


def _shared_case(n_samples: int = 3000, seed: int = 4
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Output 0 steps its gain with the regime of s; output 1 is one linear model."""
    X, y, S = _regimes(n_samples, seed)
    rng = np.random.default_rng(seed + 1)
    y2 = X @ np.array([0.5, -1.0, 0.3]) + 0.1 + 0.01 * rng.normal(size=n_samples)
    return X, np.c_[y, y2], S


def test_a_shared_output_is_one_linear_model_learnt_by_plain_rls() -> None:
    X, Y, S = _shared_case()
    ranges = dict(x_range=np.c_[X.min(0), X.max(0)], y_range=np.c_[Y.min(0), Y.max(0)],
                  s_range=np.c_[S.min(0), S.max(0)])
    model = ETS(radius=0.3, clustering="evq", forgetting=1.0, shared_outputs=(1,), **ranges)
    model.run(X, Y, S)
    assert model.n_rules >= 2  # the rules still split output 0 by regime
    raw = model.consequents_raw()  # (R, n+1, m) in original units
    np.testing.assert_array_equal(np.ptp(raw[:, :, 1], axis=0), 0.0)
    # plain RLS from a prior omega·I equals ridge least squares with weight 1/omega
    Xe = np.c_[np.ones(len(X)), (X - ranges["x_range"][:, 0]) / np.ptp(ranges["x_range"], 1)]
    theta = np.linalg.solve(Xe.T @ Xe + np.eye(4) / model.omega, Xe.T @ Y[:, 1])
    np.testing.assert_allclose(model.state_["Pi"][0, :, 1], theta, rtol=1e-6, atol=1e-9)
    # unshared, the same output gets one local model per rule, not one for all
    split = ETS(radius=0.3, clustering="evq", forgetting=1.0, **ranges)
    split.run(X, Y, S)
    assert np.ptp(split.consequents_raw()[:, :, 1], axis=0).max() > 1e-3


def test_shared_outputs_round_trip_and_refusals(tmp_path) -> None:
    X, Y, S = _shared_case(800)
    model = ETS(radius=0.3, clustering="evq", shared_outputs=(1,))
    model.run(X[:600], Y[:600], S[:600])
    model.save(tmp_path / "m.json")
    back = ETS.load(tmp_path / "m.json")
    assert back.shared_outputs == [1]
    back.run(X[600:], Y[600:], S[600:])
    model.run(X[600:], Y[600:], S[600:])
    R = model.n_rules
    assert back.n_rules == R
    np.testing.assert_array_equal(back.state_["Pi"][:R], model.state_["Pi"][:R])
    np.testing.assert_array_equal(back.state_["Cs"], model.state_["Cs"])
    with pytest.raises(ValueError, match="local RLS"):
        ETS(rls="global", shared_outputs=(0,)).run(X, Y, S)
    with pytest.raises(ValueError, match="output indices"):
        ETS(shared_outputs=(2,)).run(X, Y, S)


def test_shared_outputs_in_a_damaged_rule_base_are_refused_in_one_line() -> None:
    X, Y, S = _shared_case(300)
    model = ETS(radius=0.3, clustering="evq", shared_outputs=(1,))
    model.run(X, Y, S)
    good = model.to_dict()
    for damage, match in (
        (lambda d: d["params"].__setitem__("shared_outputs", [2]), "output indices"),
        (lambda d: d["params"].__setitem__("shared_outputs", [1, 1]), "non-unique"),
        (lambda d: d["learner"].__setitem__("shared_covariance", None), "shared_covariance"),
        (lambda d: d["learner"].__setitem__("shared_covariance", [[1.0]]), "shape"),
    ):
        data = json.loads(json.dumps(good))
        damage(data)
        with pytest.raises(ModelError, match=match):
            ETS.from_dict(data)


def test_a_trusted_dict_skips_the_schema_but_not_the_shape_checks() -> None:
    X, y, S = _regimes(300)
    model = ETS(radius=0.3, clustering="evq")
    model.run(X, y, S)
    good = model.to_dict()
    back = ETS.from_dict(good, trusted=True)
    np.testing.assert_array_equal(back.predict(X, S), model.predict(X, S))
    schema_only = json.loads(json.dumps(good))
    schema_only["params"]["variant"] = "ets++"  # caught by the schema only
    with pytest.raises(ModelError, match="params/variant"):
        ETS.from_dict(schema_only)
    shape = json.loads(json.dumps(good))
    shape["rules"][0]["consequent"] = [[0.0]]
    with pytest.raises(ModelError, match="shape"):
        ETS.from_dict(shape, trusted=True)
