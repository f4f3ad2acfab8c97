"""The ETS estimator API: parameters, input checks, history, readable rules, import hygiene."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from etsid.ets import ETS
from etsid.ets.params import DEFAULTS, PARAM_NAMES
from etsid.ets.reference import ReferenceETS


def _data(N: int = 400) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, size=(N, 2))
    return X, np.c_[np.sin(3 * X[:, 0]), X[:, 0] * X[:, 1]]


def test_init_stores_parameters_only() -> None:
    model = ETS(radius=0.2, omega=50.0, variant="ets", max_rules=7, rls="global")
    assert not [a for a in vars(model) if a.endswith("_")]
    params = model.get_params()
    assert params["radius"] == 0.2 and params["rls"] == "global" and params["max_rules"] == 7
    assert model.n_rules == 0 and len(model) == 0


def test_defaults_come_from_params_and_the_reference_shares_them() -> None:
    params = ETS().get_params()
    per_data = {"x_range", "y_range", "s_range", "input_names", "output_names",
                "antecedent_names", "shared_outputs"}
    assert set(params) == {*PARAM_NAMES, *per_data}
    assert {k: params[k] for k in PARAM_NAMES} == DEFAULTS.to_dict()
    X, Y = _data(300)
    yhat = ETS().run(X, Y)
    yref = ReferenceETS(2, 2, np.full(2, DEFAULTS.radius)).run(X, Y)
    np.testing.assert_allclose(yhat[1:], yref[1:], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize(
    ("X", "Y", "match"),
    [
        (np.zeros(5), np.zeros(5), "2-D"),
        (np.zeros((5, 2)), np.zeros(4), "rows"),
        (np.c_[np.zeros(5), [0, 0, np.nan, 0, 0]], np.zeros(5), r"NaN or inf\), first at row 2"),
        (np.zeros((5, 2)), np.r_[0, 0, 0, np.inf, 0], "Y contains"),
        (np.zeros((5, 0)), np.zeros(5), "no columns"),
    ],
)
def test_bad_arrays_raise_value_error(X, Y, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        ETS().run(X, Y)


def test_finite_values_whose_sum_overflows_are_accepted() -> None:
    # the finiteness check sums the array first; an overflowing sum of finite values must
    # not be taken for a NaN or inf
    X = np.array([[1e308, 1e308], [1e308, -1e308], [-1e308, 1e308]])
    ETS().run(X, np.zeros(3))
    with pytest.raises(ValueError, match=r"first at row 2, column 0"):
        ETS().run(np.r_[X, [[-np.inf, 0.0]]][1:], np.zeros(3))


def test_history_keeps_kernel_events_snapshots_and_later_events_in_order() -> None:
    X, Y = _data(2000)
    model = ETS(radius=0.3, history_every=100)
    model.run(X[:1000], Y[:1000])
    first = model.history
    model.run(X[1000:], Y[1000:])
    model.recorder_.add_event(2000, "merge", 0)
    h = model.history
    steps = [e["step"] for e in h.events]
    assert steps == sorted(steps) and h.events[-1]["kind"] == "merge"
    assert h.events[: len(first.events)] == first.events
    assert {e["kind"] for e in h.events[:-1]} <= {"birth", "replace", "removal"}
    assert [s["step"] for s in h.snapshots] == list(range(100, 2001, 100))
    last = h.snapshots[-1]
    np.testing.assert_array_equal(last["rule_ids"], model.export_state().rule_ids)
    np.testing.assert_array_equal(last["consequents"], model.consequents_raw())


def test_width_must_stay_the_same() -> None:
    X, Y = _data()
    model = ETS()
    model.run(X, Y)
    with pytest.raises(ValueError, match="X must have 2 columns"):
        model.predict(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="Y must have 2 columns"):
        model.run(X, Y[:, 0])


@pytest.mark.parametrize(
    "kwargs",
    [dict(variant="exts"), dict(rls="both"), dict(radius=0.0), dict(forgetting=1.5),
     dict(max_rules=0), dict(radius=[0.1, 0.2, 0.3]), dict(x_range=[[1.0, 0.0], [0, 1]])],
)  # fmt: skip
def test_bad_parameters_raise_value_error(kwargs) -> None:
    X, Y = _data(10)
    with pytest.raises(ValueError):
        ETS(**kwargs).run(X, Y)


def test_predict_before_learning_raises() -> None:
    with pytest.raises(ValueError, match="not learned"):
        ETS().predict(np.zeros((2, 2)))


def test_learn_one_equals_run() -> None:
    X, Y = _data(200)
    a = ETS(radius=0.3)
    ya = a.run(X, Y)
    b = ETS(radius=0.3)
    yb = []
    for x, y in zip(X, Y, strict=True):
        yb.append(b.predict_one(x) if b.n_rules else np.full(2, np.nan))
        b.learn_one(x, y)
    np.testing.assert_array_equal(np.array(yb), ya)
    for name, arr in a.state_.items():
        np.testing.assert_array_equal(b.state_[name], arr, err_msg=name)


def test_one_dimensional_y_round_trips_shapes() -> None:
    X, Y = _data()
    model = ETS()
    assert model.run(X, Y[:, 0]).shape == (400,)
    assert model.predict(X).shape == (400,)
    assert model.predict_one(X[0]).shape == (1,)


def test_history_frame_events_and_snapshots() -> None:
    X, Y = _data(2500)
    model = ETS(radius=0.3, history_every=1000, coverage=True)
    model.run(X[:1500], Y[:1500])
    model.run(X[1500:], Y[1500:])
    frame = model.history_frame()
    assert list(frame.columns) == ["step", "n_rules", "potential", "focal_max", "focal_min"]
    assert frame["step"].tolist() == list(range(1, 2501))
    h = model.history
    assert {e["kind"] for e in h.events} <= {"birth", "replace", "removal"}
    assert h.events[0] == {"step": 1, "kind": "birth", "rule_id": 0}
    assert [s["step"] for s in h.snapshots] == [1000, 2000]
    snap = h.snapshots[-1]
    assert snap["consequents"].shape == (len(snap["rule_ids"]), 3, 2)
    assert list(h.events_frame().columns) == ["step", "kind", "rule_id"]
    n = np.zeros(2501, dtype=int)  # replay the events: the rule count must match the history
    for e in h.events:
        n[e["step"] :] += {"birth": 1, "replace": 0, "removal": -1}[e["kind"]]
    np.testing.assert_array_equal(n[1:], h.n_rules)


def test_rules_are_printed_in_original_units() -> None:
    rng = np.random.default_rng(1)
    x = rng.uniform(10.0, 20.0, size=(300, 1))
    y = 1.0 + 2.0 * x[:, 0]
    model = ETS(variant="ets", max_rules=1, input_names=["thrust"], output_names=["az"])
    model.run(x, y)
    np.testing.assert_allclose(model.consequents_raw()[0, :, 0], [1.0, 2.0], atol=1e-3)
    text = model.rules()
    assert "IF thrust ≈" in text and "THEN az = 1 + 2·thrust" in text


@pytest.mark.parametrize("rls", ["local", "global"])
def test_exported_state_is_read_only_and_restores_the_same_model(rls: str) -> None:
    X, Y = _data()
    model = ETS(radius=0.3, rls=rls, input_names=["a", "b"])
    model.run(X[:200], Y[:200])
    state = model.export_state()
    assert state.n_rules == model.n_rules >= 2 and state.samples == 200
    assert state.focal_points.shape == (model.n_rules, 4)
    with pytest.raises(ValueError, match="read-only"):
        state.focal_points[0, 0] = 1.0
    copy = ETS(**model.get_params()).restore_state(state)
    for f in dataclasses.fields(state):  # slots beyond the live rules are not state
        np.testing.assert_array_equal(getattr(copy.export_state(), f.name),
                                      getattr(state, f.name), err_msg=f.name)
    np.testing.assert_array_equal(copy.run(X[200:], Y[200:]), model.run(X[200:], Y[200:]))
    assert copy.names() == (["a", "b"], ["y1", "y2"])
    np.testing.assert_array_equal(copy.scales(), model.scales())
    with pytest.raises(ValueError, match="max_rules"):
        ETS(max_rules=1).restore_state(state)
    with pytest.raises(ValueError, match="not learned"):
        ETS().export_state()


def test_core_imports_nothing_else_of_etsid() -> None:
    code = (
        "import sys, etsid.ets, etsid.ets.serialize, etsid.ets.text, etsid.ets.reference;"
        "print(sorted(m for m in sys.modules if m.startswith('etsid')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    mods = eval(out.stdout)
    # etsid.files: the one opener every file is read through (standard library only);
    # etsid.cachedir: the package root points numba at the user cache (issue 43)
    assert all(m in ("etsid", "etsid.errors", "etsid.files", "etsid.cachedir")
               or m.startswith("etsid.ets")
               for m in mods), mods
