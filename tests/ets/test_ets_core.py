"""eTS core against its definitions: potentials, RLS, numpy reference, JSON round trip."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from etsid.errors import ModelError
from etsid.ets import ETS
from etsid.ets.reference import (
    ReferenceETS,
    brute_force_potential,
    recursive_focal_update,
    recursive_potential,
)


def _stream(n_samples: int = 300, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = np.cumsum(rng.normal(size=(n_samples, 3)), axis=0) * 0.1 + rng.normal(size=(n_samples, 3))
    Y = np.c_[np.sin(X[:, 0]) + X[:, 1] * X[:, 2], X[:, 0] - X[:, 2] ** 2]
    return X, Y


@settings(max_examples=25, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(2, 40), st.integers(1, 5)),
              elements=st.floats(-10, 10)))  # fmt: skip
def test_recursive_potential_equals_definition(Z: np.ndarray) -> None:
    np.testing.assert_allclose(recursive_potential(Z), brute_force_potential(Z), rtol=1e-9)


def test_focal_recursion_matches_definition() -> None:
    rng = np.random.default_rng(0)
    Z = rng.normal(size=(60, 3))
    p = 1.0 / (1.0 + np.sum((Z[:10] - Z[9]) ** 2) / 9)  # focal point z_10 at k = 10
    for k in range(11, 61):
        p = recursive_focal_update(p, k, float(np.sum((Z[9] - Z[k - 1]) ** 2)))
        want = 1.0 / (1.0 + np.sum((Z[:k] - Z[9]) ** 2) / (k - 1))
        assert p == pytest.approx(want, rel=1e-12)


def test_kernel_potential_is_the_definition_with_fixed_ranges() -> None:
    rng = np.random.default_rng(2)
    X = rng.normal(size=(200, 2))
    Y = rng.normal(size=(200, 1))
    rx, ry = [[-4.0, 4.0], [-3.0, 5.0]], [[-5.0, 5.0]]
    model = ETS(x_range=rx, y_range=ry)
    model.run(X, Y)
    lo = np.array([-4.0, -3.0, -5.0])
    Z = (np.c_[X, Y] - lo) / np.array([8.0, 8.0, 10.0])
    np.testing.assert_allclose(model.history.potential, recursive_potential(Z), rtol=1e-9)


def test_kernel_potential_with_running_ranges_uses_current_ranges() -> None:
    # running min/max: P_k is the definition evaluated with the ranges at step k, no drift
    rng = np.random.default_rng(3)
    Zr = rng.normal(size=(150, 3)) * [1.0, 100.0, 0.01]
    model = ETS()
    model.run(Zr[:, :2], Zr[:, 2])
    for k in (2, 10, 75, 150):
        seen = Zr[:k]
        span = seen.max(0) - seen.min(0)
        Zn = seen / span
        want = 1.0 / (1.0 + np.sum((Zn - Zn[-1]) ** 2) / (k - 1))
        assert model.history.potential[k - 1] == pytest.approx(want, rel=1e-9)


def test_one_rule_local_rls_equals_batch_least_squares() -> None:
    rng = np.random.default_rng(4)
    X = rng.uniform(-1, 1, size=(400, 3))
    Y = X @ [[1.0, -2.0], [0.5, 0.0], [-1.5, 3.0]] + [0.3, -0.7] + 0.05 * rng.normal(size=(400, 2))
    model = ETS(max_rules=1, omega=1e8, x_range=[[-1, 1]] * 3, variant="ets", forgetting=1.0)
    model.run(X, Y)
    A = np.c_[np.ones(400), X]
    theta = np.linalg.lstsq(A, Y, rcond=None)[0]
    np.testing.assert_allclose(model.consequents_raw()[0], theta, atol=1e-5)


CONFIGS = [
    dict(variant=v, rls=r, adaptive_spread=a, coverage=c, forgetting=f)
    for v, r, a, c, f in itertools.product(
        ["ets", "ets+"], ["local", "global"], [False, True], [False, True], [1.0, 0.97]
    )
    if not (v == "ets" and c)
] + [dict(variant=v, clustering="evq", rls=r) for v in ("ets", "ets+")
     for r in ("local", "global")]


@pytest.mark.parametrize("cfg", CONFIGS, ids=lambda c: "-".join(str(v) for v in c.values()))
def test_kernels_equal_numpy_reference(cfg: dict) -> None:
    X, Y = _stream()
    kw = dict(
        omega=1000.0, max_rules=8, utility_threshold=0.1, min_support=3, prune_after=30, **cfg
    )
    model = ETS(radius=0.3, history_every=37, **kw)
    Yhat = model.run(X, Y)
    ref = ReferenceETS(3, 2, np.full(3, 0.3), **kw)
    Yref = ref.run(X, Y)
    np.testing.assert_allclose(Yhat[1:], Yref[1:], rtol=1e-9, atol=1e-9)
    assert [(e["step"], e["kind"], e["rule_id"]) for e in model.history.events] == ref.events
    want = ref.state()
    R = model.n_rules
    np.testing.assert_allclose(model.state_["Pi"][:R], want["Pi"], rtol=1e-9, atol=1e-8)
    np.testing.assert_allclose(model.state_["pot"][:R], want["pot"], rtol=1e-9)
    np.testing.assert_array_equal(model.state_["support"][:R], want["support"])
    h = np.array(ref.history)
    np.testing.assert_allclose(model.history.potential, h[:, 1], rtol=1e-9)
    np.testing.assert_array_equal(model.history.n_rules, h[:, 0])


def _held_stream(n_samples: int, seed: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """A slow input, one input held constant (a held command), one of sensor noise."""
    rng = np.random.default_rng(seed)
    k = np.arange(n_samples)
    X = np.c_[np.sin(k / 50.0), np.full(n_samples, 0.3), 0.001 * rng.normal(size=n_samples)]
    return X, np.c_[X[:, 0] ** 2, X[:, 0] - X[:, 2]]


@pytest.mark.parametrize("rls", ["local", "global"])
@pytest.mark.parametrize("forgetting", [1.0, 0.9])
def test_kernels_equal_numpy_reference_on_a_held_input(rls: str, forgetting: float) -> None:
    # with f < 1 the held input's direction is never excited: the wind-up guard engages
    X, Y = _held_stream(600)
    kw = dict(omega=1000.0, rls=rls, forgetting=forgetting, max_rules=8, prune_after=30)
    model = ETS(radius=0.3, **kw)
    Yhat = model.run(X, Y)
    ref = ReferenceETS(3, 2, np.full(3, 0.3), **kw)
    Yref = ref.run(X, Y)
    np.testing.assert_allclose(Yhat[1:], Yref[1:], rtol=1e-9, atol=1e-9)
    assert [(e["step"], e["kind"], e["rule_id"]) for e in model.history.events] == ref.events
    R = model.n_rules
    np.testing.assert_allclose(model.state_["Pi"][:R], ref.state()["Pi"], rtol=1e-9, atol=1e-8)
    if rls == "local":
        C, Cref = model.state_["Cl"][:R], np.array([r.C for r in ref.rules])
    else:
        C, Cref = model.state_["Cg"][: 4 * R, : 4 * R], ref.Cg
    np.testing.assert_allclose(C, Cref, rtol=1e-9, atol=1e-6)
    if forgetting < 1.0:  # the guard did engage: a trace sits at its bound
        traces = np.trace(C, axis1=-2, axis2=-1) / (4 * 1000.0 * (1 if rls == "local" else R))
        assert np.max(traces) > 0.9


@pytest.mark.parametrize("rls", ["local", "global"])
def test_json_round_trip_is_bit_identical(tmp_path, rls: str) -> None:
    X, Y = _stream(600, seed=5)
    model = ETS(radius=0.3, rls=rls, input_names=["a", "b", "c"], output_names=["p", "q"])
    model.run(X[:300], Y[:300])
    path = tmp_path / "rules.json"
    model.save(path, regressors={"a": "p(k-1)"}, lags={"a": [1]})
    loaded = ETS.load(path)
    assert loaded.extra_ == {"regressors": {"a": "p(k-1)"}, "lags": {"a": [1]}}
    np.testing.assert_array_equal(loaded.predict(X[300:]), model.predict(X[300:]))
    np.testing.assert_array_equal(loaded.run(X[300:], Y[300:]), model.run(X[300:], Y[300:]))
    for name, arr in model.state_.items():
        np.testing.assert_array_equal(loaded.state_[name], arr, err_msg=name)
    assert loaded.to_dict() == model.to_dict()


def _saved(tmp_path) -> tuple[dict, object]:
    X, Y = _stream(100)
    model = ETS(radius=0.3)
    model.run(X, Y)
    return model.to_dict(), tmp_path / "rules.json"


BREAKAGES = {
    "wrong schema": (lambda d: d.update(schema="etsid.rules/3"), "schema"),
    "missing rules": (lambda d: d.pop("rules"), "rules"),
    "string potential": (lambda d: d["rules"][0].update(potential="high"), "potential"),
    "ragged consequent": (lambda d: d["rules"][0]["consequent"].pop(), "consequent"),
    "unknown variant": (lambda d: d["params"].update(variant="exec"), "variant"),
    "extra field": (lambda d: d.update(__import__="os"), "__import__"),
    "duplicate ids": (lambda d: d["rules"][1].update(id=d["rules"][0]["id"]), "ids"),
    "short focal point": (lambda d: d["rules"][0]["focal_point"].pop(), "focal_point"),
    "negative radius": (lambda d: d["rules"][0].update(radius=[-1.0, 1.0, 1.0]), "radius"),
}


@pytest.mark.parametrize("name", list(BREAKAGES))
def test_malformed_rule_base_is_rejected(tmp_path, name: str) -> None:
    data, path = _saved(tmp_path)
    breakage, match = BREAKAGES[name]
    breakage(data)
    path.write_text(json.dumps(data))
    with pytest.raises(ModelError, match=match):
        ETS.load(path)
    with pytest.raises(ModelError):
        ETS.from_dict(data)


@pytest.mark.parametrize("text", ["", "{", "[1, 2]", '{"potential": NaN}', "\x00\x01"])
def test_broken_files_give_model_error(tmp_path, text: str) -> None:
    path = tmp_path / "rules.json"
    path.write_text(text)
    with pytest.raises(ModelError, match="rules.json"):
        ETS.load(path)


def test_missing_file_gives_model_error(tmp_path) -> None:
    with pytest.raises(ModelError, match=r"nope\.json: no such file"):
        ETS.load(tmp_path / "nope.json")


def _kernel_run(monkeypatch, bounds: tuple[int, int], kw: dict, X: np.ndarray, Y: np.ndarray,
                S: np.ndarray | None = None) -> tuple[ETS, np.ndarray]:
    """Run with the kernel switch at ``bounds`` = (_RULE_MAJOR_MAX, _LANES_MIN)."""
    import etsid.ets.model as model_module

    monkeypatch.setattr(model_module, "_RULE_MAJOR_MAX", bounds[0])
    monkeypatch.setattr(model_module, "_LANES_MIN", bounds[1])
    model = ETS(**kw)
    half = len(X) // 2
    Yhat = np.concatenate([model.run(X[:half], Y[:half], None if S is None else S[:half]),
                           model.run(X[half:], Y[half:], None if S is None else S[half:])])
    return model, Yhat


SWITCH_CONFIGS = [
    dict(radius=0.25, max_rules=12, history_every=23),
    dict(radius=0.25, max_rules=12, rls="global", forgetting=0.97, history_every=23),
    dict(radius=0.2, variant="ets", max_rules=9, adaptive_spread=False, forgetting=1.0),
    dict(radius=0.2, clustering="evq", max_rules=12, shared_outputs=[1]),
]


@pytest.mark.parametrize("kw", SWITCH_CONFIGS, ids=lambda c: "-".join(str(v) for v in c.values()))
def test_rule_major_and_lanes_kernels_are_bit_identical(monkeypatch, kw: dict) -> None:
    """learn_kernel alone, learn_lanes alone and the switching between them (rule counts
    that cross the switch both ways) give the same predictions, state and history bit for
    bit."""
    X, Y = _stream(1500, seed=3)
    runs = {name: _kernel_run(monkeypatch, bounds, kw, X, Y)
            for name, bounds in (("rule-major", (10**6, 10**6)), ("lanes", (-1, -1)),
                                 ("switching", (3, 5)))}  # fmt: skip
    counts = runs["switching"][0].history.n_rules
    assert counts.max() > 3  # the switch was crossed upwards ...
    if kw.get("variant", "ets+") == "ets+":
        assert np.any(np.diff(counts) < 0)  # ... and down (removals; eTS never removes)
    base_model, base_yhat = runs["rule-major"]
    base = base_model.export_state()
    for name in ("lanes", "switching"):
        model, yhat = runs[name]
        np.testing.assert_array_equal(yhat, base_yhat, err_msg=name)
        state = model.export_state()
        for field in ("consequents", "covariances", "global_covariance", "focal_points",
                      "radii", "potentials", "support", "shared_covariance"):
            a, b = getattr(state, field), getattr(base, field)
            if a is None:
                assert b is None
                continue
            np.testing.assert_array_equal(a, b, err_msg=f"{name}: {field}")
        h, hb = model.history, base_model.history
        np.testing.assert_array_equal(h.potential, hb.potential)
        np.testing.assert_array_equal(h.n_rules, hb.n_rules)
        assert h.events == hb.events
        assert [s["step"] for s in h.snapshots] == [s["step"] for s in hb.snapshots]
        for s, sb in zip(h.snapshots, hb.snapshots, strict=True):
            np.testing.assert_array_equal(s["consequents"], sb["consequents"])
            np.testing.assert_array_equal(s["rule_ids"], sb["rule_ids"])


@pytest.mark.parametrize("bounds", [(10**6, 10**6), (-1, -1)], ids=["rule-major", "lanes"])
@pytest.mark.parametrize("rls", ["local", "global"])
def test_each_learning_kernel_equals_numpy_reference(monkeypatch, bounds, rls: str) -> None:
    X, Y = _stream(400, seed=2)
    kw = dict(omega=1000.0, max_rules=10, utility_threshold=0.1, min_support=3,
              prune_after=30, variant="ets+", rls=rls, forgetting=0.97, adaptive_spread=True)
    model, Yhat = _kernel_run(monkeypatch, bounds, dict(radius=0.25, **kw), X, Y)
    ref = ReferenceETS(3, 2, np.full(3, 0.25), **kw)
    Yref = ref.run(X, Y)
    assert model.history.n_rules.max() > 6  # both kernels see the larger rule bases
    np.testing.assert_allclose(Yhat[1:], Yref[1:], rtol=1e-9, atol=1e-9)
    assert [(e["step"], e["kind"], e["rule_id"]) for e in model.history.events] == ref.events


@pytest.mark.parametrize("scheduled", [False, True])
def test_predict_one_is_predict_bit_for_bit_and_follows_learning(scheduled: bool) -> None:
    X, Y = _stream(600, seed=4)
    S = np.c_[X[:, 0] ** 2] if scheduled else None
    model = ETS(radius=0.3, max_rules=10)
    model.run(X[:300], Y[:300], None if S is None else S[:300])
    for part in (slice(300, 400), slice(400, 600)):
        batch = model.predict(X[part], None if S is None else S[part])
        one = np.array([model.predict_one(x, None if S is None else S[part][i])
                        for i, x in enumerate(X[part])])
        np.testing.assert_array_equal(one, batch)
        # learning moves the rules: the next predictions must use the new ones
        before = model.predict_one(X[0], None if S is None else S[0])
        model.run(X[part], Y[part], None if S is None else S[part])
        np.testing.assert_array_equal(model.predict_one(X[0], None if S is None else S[0]),
                                      model.predict(X[:1], None if S is None else S[:1])[0])
        assert not np.array_equal(before, model.predict_one(X[0], None if S is None else S[0]))
    with pytest.raises(ValueError, match="non-finite"):
        model.predict_one(np.full(3, np.nan), None if S is None else S[0])


@pytest.mark.parametrize("kw", [
    dict(radius=0.3, max_rules=4, adaptive_spread=False, forgetting=1.0),
    dict(radius=0.3, max_rules=5, history_every=7, forgetting=0.95),
    dict(radius=0.25, max_rules=6, clustering="evq"),
], ids=["fixed", "forgetting", "evq"])  # fmt: skip
def test_pair_layout_is_bit_identical_however_the_stream_is_cut(kw: dict) -> None:
    """learn_kernel keeps pairs of rules in a work layout and sums each pair's next gain
    one sample ahead; both are written back or dropped when a call returns, the rule base
    or a range changes, or a snapshot is taken. Cutting the stream into calls of 1 to 37
    samples must not change a bit."""
    X, Y = _stream(900, seed=5)
    whole = ETS(**kw)
    y_whole = whole.run(X, Y)
    cut = ETS(**kw)
    rng = np.random.default_rng(0)
    parts, start = [], 0
    while start < len(X):
        stop = min(len(X), start + int(rng.integers(1, 38)))
        parts.append(cut.run(X[start:stop], Y[start:stop]))
        start = stop
    assert whole.history.n_rules.max() >= 3  # at least one pair was learned in place
    np.testing.assert_array_equal(np.concatenate(parts), y_whole)
    a, b = whole.export_state(), cut.export_state()
    for field in ("consequents", "covariances", "focal_points", "radii", "potentials"):
        np.testing.assert_array_equal(getattr(b, field), getattr(a, field), err_msg=field)
    assert cut.history.events == whole.history.events
