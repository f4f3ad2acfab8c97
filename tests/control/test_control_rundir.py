"""RUN_DIR of a control run: the rule base round-trips through JSON, files agree."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from etsid.control.ets_controller import INPUT_NAMES
from etsid.control.run import run_control
from etsid.ets import ETS
from etsid.table import load_table


@pytest.fixture(scope="module")
def ets_run(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("ctl") / "RUN"
    return run_control("ige-sine", "ets", duration=20.0, seed=3, out=out)


def test_rule_base_round_trips_through_json(ets_run) -> None:
    model = ets_run.flight.controller.model
    loaded = ETS.load(ets_run.run_dir / "rules.json")
    assert loaded.n_rules == model.n_rules == ets_run.metrics["rules_final"] > 0
    assert loaded.names()[0] == list(INPUT_NAMES)
    rng = np.random.default_rng(0)
    X = np.column_stack([rng.uniform(0.3, 1.2, 500), rng.uniform(-0.4, 0.4, 500),
                         rng.uniform(-0.9, 0.9, 500)])
    np.testing.assert_array_equal(loaded.predict(X), model.predict(X))  # bit for bit
    data = json.loads((ets_run.run_dir / "rules.json").read_text())
    assert data["schema"] == "etsid.rules/2" and data["outputs"] == ["u_thrust"]


def test_run_dir_files_agree(ets_run) -> None:
    run_dir: Path = ets_run.run_dir
    metrics = json.loads((run_dir / "metrics.json").read_text())
    config = json.loads((run_dir / "config.json").read_text())
    assert config["kind"] == "control" and config["controller"] == "ets"
    assert config["scenario"]["name"] == "ige-sine" and config["seed"] == 3
    assert metrics["tracking_rmse"] == pytest.approx(ets_run.metrics["tracking_rmse"])
    flight = load_table(run_dir / "flight.parquet")
    assert len(flight) == 1000 and flight.index[1] == pytest.approx(0.02)
    pd.testing.assert_frame_equal(flight, ets_run.flight.table, check_like=True)
    err = flight["alt_ref"] - flight["true_alt"]
    assert np.sqrt(np.mean(err[flight.index >= 10.0] ** 2)) == pytest.approx(
        metrics["tracking_rmse"])
    hist = pd.read_parquet(run_dir / "history.parquet")
    events = pd.read_parquet(run_dir / "events.parquet")
    assert hist["replacements"].iloc[-1] == metrics["rule_replacements"] == (
        events["kind"] == "replace").sum()
    assert hist["births"].iloc[-1] == metrics["rule_births"]
    assert hist["n_rules"].iloc[-1] == metrics["rules_final"]
    assert np.all(np.diff(hist["t"]) > 0) and hist["t"].iloc[-1] < 20.0
    # the running bounds: P_min <= P_max, all potentials in (0, 1]
    assert np.all(hist["focal_min"] <= hist["focal_max"] + 1e-12)
    assert np.all((hist["potential"] > 0) & (hist["potential"] <= 1))


def test_same_seed_same_flight_other_seed_other_noise(tmp_path: Path) -> None:
    a = run_control("hover-ige", "pid", duration=3.0, seed=5).flight.table
    b = run_control("hover-ige", "pid", duration=3.0, seed=5).flight.table
    c = run_control("hover-ige", "pid", duration=3.0, seed=6).flight.table
    pd.testing.assert_frame_equal(a, b)
    assert not np.allclose(a["alt"], c["alt"])
