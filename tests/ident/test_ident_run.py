"""identify / predict with the eTS core on synthetic rate data and Box–Jenkins."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.errors import IdentError
from etsid.ets import ETS
from etsid.ident import IdentConfig, identify, predict, read_run, write_run
from etsid.ident.arx import ARX
from etsid.ident.regressors import RegressorSpec, build
from etsid.ident.simulate import free_run
from etsid.ident.synthetic import rate_table

DATA = Path(__file__).parents[1] / "data"


@pytest.fixture(scope="module")
def table() -> pd.DataFrame:
    return rate_table(3000, seed=4, sigma=0.01)


@pytest.fixture(scope="module")
def run_dir(table: pd.DataFrame, tmp_path_factory: pytest.TempPathFactory) -> Path:
    # the synthetic table is an exact difference equation at its own 250 Hz (Euler steps),
    # so it is identified at that rate with two command lags; the 50 Hz default is tested
    # on the simulated hexacopter in tests/test_ident_quality.py
    run = identify(table, IdentConfig(validate=0.3, ident_rate=0, input_lags=2))
    return write_run(run, tmp_path_factory.mktemp("run") / "RUN")


def test_identify_file_contract(run_dir: Path, table: pd.DataFrame) -> None:
    run = read_run(run_dir)
    pred = run.predictions
    for y in ("p", "q", "r"):
        assert {y, f"{y}_hat", f"{y}_sim", f"{y}_arx"} <= set(pred.columns)
    assert pred.columns[0] == "t"
    # 2 segments x 4 lags without history
    assert run.metrics["skipped"] == {"history": 8, "missing": 0}
    assert run.metrics["n_samples"] == len(table) - 8 == len(pred)
    val = pred["part"] == "validation"
    # the validation part holds the last 30 % of the excited rows (all rows here, ±1)
    assert abs(val.sum() - round(0.3 * len(pred))) <= 2
    assert pred.loc[~val, "p_sim"].isna().all() and pred.loc[val, "p_sim"].notna().all()
    m = run.metrics["outputs"]["p"]
    assert set(m) >= {"online", "validation", "arx"}
    assert set(m["online"]) >= {"rmse", "ndei", "vaf", "fit"}
    assert set(m["validation"]) == {"one_step", "free_run"}
    assert m["noise_std"] == 0.01
    assert run.metrics["rules"]["peak"] >= run.metrics["rules"]["final"] >= 1
    assert run.config["input"]["rows"] == len(table)
    assert run.config["model"]["regressors"].startswith("p[k-1],p[k-2],p[k-3],p[k-4],q[k-1]")
    assert run.config["etsid_version"]
    hist = pd.read_parquet(run_dir / "history.parquet")
    assert {"step", "t", "n_rules", "potential", "focal_max", "focal_min", "births"} <= set(
        hist.columns)
    assert hist["births"].sum() >= run.metrics["rules"]["peak"]


def test_identify_quality_near_noise_floor(run_dir: Path) -> None:
    run = read_run(run_dir)
    m = run.metrics["outputs"]
    pred = run.predictions
    for y in ("p", "q", "r"):
        one = m[y]["validation"]["one_step"]["rmse"]
        persistence = np.sqrt(np.mean(np.diff(pred[y].to_numpy()) ** 2))
        assert one < min(2.5 * 0.01, persistence)
        assert m[y]["online"]["rmse"] < 2.0 * 0.01
        assert m[y]["validation"]["free_run"]["fit"] > 80.0


def test_rules_json_validates_and_rebuilds_regressors(run_dir: Path) -> None:
    data = json.loads((run_dir / "rules.json").read_text())
    assert data["schema"] == "etsid.rules/2"
    model = ETS.from_dict(data)  # schema-checked
    spec = RegressorSpec.from_dict(data["regressors"])
    assert model.n_inputs_ == len(spec.terms) == 3 * 4 + 4 * 2


def test_predict_reproduces_frozen_validation_exactly(run_dir: Path,
                                                      table: pd.DataFrame) -> None:
    ident = read_run(run_dir)
    t0 = ident.metrics["validation"]["t_start"]
    run = predict(table, run_dir / "rules.json", sim_from=t0, fallback=False)  # eTS only
    a, b = ident.predictions, run.predictions
    val = a["part"] == "validation"
    for y in ("p", "q", "r"):
        np.testing.assert_array_equal(a.loc[val, f"{y}_val"], b.loc[val, f"{y}_hat"])
        np.testing.assert_array_equal(a[f"{y}_sim"], b[f"{y}_sim"])
        assert (ident.metrics["outputs"][y]["validation"]
                == run.metrics["outputs"][y]["validation"])


def test_predict_with_learning_continues(run_dir: Path, table: pd.DataFrame) -> None:
    run = predict(table, run_dir, learn=True)
    assert len(run.history) == run.metrics["n_samples"]
    assert run.rules_final is not None
    frozen = predict(table, run_dir)
    assert not np.array_equal(run.predictions["p_hat"], frozen.predictions["p_hat"])


def test_free_run_feeds_back_its_own_outputs() -> None:
    # y_k = 0.5 y_{k-1} + u_{k-1}: an exact ARX; free-run from measured ICs is exact
    n = 50
    u = np.sin(np.arange(n))
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.5 * y[k - 1] + u[k - 1]
    frame = pd.DataFrame({"y": y, "u": u}, index=pd.Index(np.arange(n) * 1.0, name="t"))
    spec = RegressorSpec.parse("y[k-1],u[k-1]", ["y"])
    reg = build(frame, spec)
    model = ARX.fit(reg.X, reg.Y, ridge=0.0)
    sim = free_run(model.predict_one, reg, spec, 10, n)
    np.testing.assert_allclose(sim[:, 0], y[11:], atol=1e-9)
    # a biased model drifts only through its own feedback
    biased = ARX(model.theta + np.array([[0.1], [0.0], [0.0]]))
    sim = free_run(biased.predict_one, reg, spec, 10, n)
    assert sim[-1, 0] - y[-1] == pytest.approx(0.1 / (1 - 0.5), rel=1e-6)


def test_box_jenkins_python_api() -> None:
    frame = pd.read_csv(DATA / "gas_furnace.csv")
    frame.index = pd.Index(np.arange(len(frame)) * 9.0, name="t")
    run = identify(frame, IdentConfig(outputs=["co2"],
                                      regressors="co2[k-1],input_gas_rate[k-4]",
                                      validate=0.0))
    m = run.metrics["outputs"]["co2"]
    assert run.metrics["n_samples"] == 292
    assert m["online"]["rmse"] < 0.6
    assert m["arx"]["online"]["rmse"] < 0.7
    assert m["validation"] is None


def test_refusals(table: pd.DataFrame) -> None:
    with pytest.raises(IdentError, match="--output needs --regressors"):
        identify(table, IdentConfig(outputs=["p"]))
    with pytest.raises(IdentError, match="needs p, q, r: no data in r"):
        identify(table.drop(columns=["r"]))
    with pytest.raises(IdentError, match="too few to learn"):
        identify(table.iloc[:12], IdentConfig(validate=0.5, ident_rate=0, input_lags=2,
                                              segments="all"))
    with pytest.raises(IdentError, match="bad eTS parameter"):
        identify(table, IdentConfig(variant="nope"))
    with pytest.raises(IdentError, match="--normalise 'minmax'"):
        identify(table, IdentConfig(normalise="minmax", ident_rate=0, input_lags=2))


def test_learn_ranges_are_the_learning_part_widened(table: pd.DataFrame) -> None:
    from etsid.ident.ranges import RANGE_MARGIN

    config = IdentConfig(validate=0.3, ident_rate=0, input_lags=2)
    run = identify(table, config)
    assert run.config["parameters"]["normalise"] == "learn"
    spec = RegressorSpec.from_dict(run.rules["regressors"])
    reg = build(table, spec)
    split = run.metrics["validation"]["n_learn"]
    lo, hi = reg.X[:split].min(0), reg.X[:split].max(0)
    width = hi - lo
    x_range = np.asarray(run.rules["params"]["x_range"])
    np.testing.assert_allclose(x_range[:, 0], lo - RANGE_MARGIN * width)
    np.testing.assert_allclose(x_range[:, 1], hi + RANGE_MARGIN * width)
    y_range = np.asarray(run.rules["params"]["y_range"])
    np.testing.assert_allclose(y_range[:, 1], reg.Y[:split].max(0)
                               + RANGE_MARGIN * np.ptp(reg.Y[:split], axis=0))
    # nothing of the validation part leaks into the ranges
    other = identify(table, IdentConfig(validate=0.5, ident_rate=0, input_lags=2))
    assert other.rules["params"]["x_range"] != run.rules["params"]["x_range"]


def test_apriori_ranges_for_loop_commands(table: pd.DataFrame) -> None:
    run = identify(table, IdentConfig(ident_rate=0, input_lags=2, normalise="apriori"))
    spec = RegressorSpec.from_dict(run.rules["regressors"])
    x_range = run.rules["params"]["x_range"]
    for term, rng in zip(spec.terms, x_range, strict=True):
        if term.name == "u_thrust":
            assert rng == [0.0, 1.0]
        elif term.name.startswith("u_"):
            assert rng == [-1.0, 1.0]
        else:
            assert rng[0] < 0 < rng[1] and rng != [-1.0, 1.0]


def test_constant_column_gets_a_unit_range() -> None:
    from etsid.ident.ranges import learn_range

    assert learn_range(np.full(10, 0.5)) == (0.0, 1.0)
    assert learn_range(np.array([np.nan, 2.0, 2.0])) == (1.5, 2.5)
    assert learn_range(np.array([0.0, 1.0])) == pytest.approx((-0.05, 1.05))


@pytest.mark.parametrize("mode", ["running", "apriori"])
def test_predict_reproduces_validation_in_every_mode(table: pd.DataFrame, tmp_path: Path,
                                                     mode: str) -> None:
    run = identify(table, IdentConfig(ident_rate=0, input_lags=2, normalise=mode))
    write_run(run, tmp_path / "RUN")
    again = predict(table, tmp_path / "RUN" / "rules.json",
                    sim_from=run.metrics["validation"]["t_start"])
    for y in ("p", "q", "r"):  # the model rules.json holds: eTS, or with its fall-back
        block = run.metrics["outputs"][y]
        assert (block.get("applied") or block)["validation"] == again.metrics["outputs"][y][
            "validation"]
