"""The per-axis fall-back travels with the rule base (issue 41): identify saves ARX or
no-change in rules.json where eTS was behind on its validation, ``etsid predict`` applies
it, and a rules.json without the block predicts as before.

Known answers: the synthetic rate table (yaw τ = 0.15 s identified at 50 Hz, where one
recursive rule is behind batch least squares by more than 2 % on r) falls back to ARX on r;
the shared ArduCopter 4.0.3 hexa falls back to no-change on r (docs/identify.md's table).
predict on the same table from identify's validation start must give, for the fall-back
axis, identify's own ARX (or no-change) validation one-step numbers, and for the free run of
every axis identify's ``applied`` numbers (the mixed model fed back its own outputs)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from etsid.errors import IdentError
from etsid.ident import IdentConfig, identify, predict, write_run
from etsid.ident.arx import ARX
from etsid.ident.inputs import load_for_ident
from etsid.ident.synthetic import rate_table

REAL = Path(__file__).parents[1] / "data" / "ardupilot_copter403_hexa_loiter_real.bin"
KEYS = ("rmse", "ndei", "vaf", "fit", "n")


def _close(a: dict, b: dict) -> None:
    for k in KEYS:
        if a[k] is None or b[k] is None:
            assert a[k] is None and b[k] is None, k
        else:
            assert b[k] == pytest.approx(a[k], rel=0, abs=1e-9), k


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory: pytest.TempPathFactory) -> tuple[pd.DataFrame, Path, dict]:
    table = rate_table(6000, seed=4)
    run = identify(table, IdentConfig(segments="all"))
    out = write_run(run, tmp_path_factory.mktemp("fb") / "RUN")
    return table, out, run.metrics


def test_identify_saves_the_arx_fitted_on_the_learning_part(synthetic) -> None:  # type: ignore[no-untyped-def]
    table, out, metrics = synthetic
    used = {y: b["used"] for y, b in metrics["outputs"].items()}
    assert used == {"p": "eTS", "q": "eTS", "r": "ARX"}  # the known case (module docstring)
    rules = json.loads((out / "rules.json").read_text())
    assert set(rules["fallback"]) == {"r"}
    block = rules["fallback"]["r"]
    assert block["model"] == "ARX" and block["reason"] == "eTS was behind on its validation"
    # the same fit as the validation baseline: ARX on the learning rows, column r
    from etsid.ident.regressors import RegressorSpec, build
    from etsid.ident.resample import decimate

    spec = RegressorSpec.from_dict(rules["regressors"])
    reg = build(decimate(table, rules["regressors"]["sample_rate_hz"]), spec)
    split = metrics["validation"]["n_learn"]
    theta = ARX.fit(reg.X[:split], reg.Y[:split]).theta[:, 2]
    np.testing.assert_allclose(block["theta"], theta, rtol=1e-12, atol=1e-15)
    assert len(block["theta"]) == len(spec.terms) + 1


def test_identify_says_what_the_fall_back_costs_in_free_run(synthetic) -> None:  # type: ignore[no-untyped-def]
    _, out, metrics = synthetic
    notes = json.loads((out / "config.json").read_text())["model"]["notes"]
    line = next(n for n in notes if n.startswith("rules.json saves the fall-back"))
    fit = {y: (metrics["outputs"][y]["applied"]["validation"]["free_run"]["fit"],
               metrics["outputs"][y]["validation"]["free_run"]["fit"]) for y in "pqr"}
    assert line == ("rules.json saves the fall-back (r ARX; etsid predict applies it, "
                    "--no-fallback not): validation free-run fit % p / q / r "
                    + " / ".join(f"{fit[y][0]:.1f}" for y in "pqr") + " with it, "
                    + " / ".join(f"{fit[y][1]:.1f}" for y in "pqr") + " eTS alone")
    assert fit["p"][0] != fit["p"][1]  # the mixed free run moves the eTS axes too


def test_predict_applies_it_and_reproduces_identify(synthetic) -> None:  # type: ignore[no-untyped-def]
    table, out, metrics = synthetic
    run = predict(table, out / "rules.json", sim_from=metrics["validation"]["t_start"],
                  segments="all")
    got = run.metrics["outputs"]
    assert {y: got[y]["used"] for y in got} == {"p": "eTS", "q": "eTS", "r": "ARX"}
    # one-step of the fall-back axis: identify's ARX validation baseline
    _close(metrics["outputs"]["r"]["arx"]["validation"]["one_step"],
           got["r"]["validation"]["one_step"])
    # one-step of the eTS axes: identify's eTS validation
    for y in ("p", "q"):
        _close(metrics["outputs"][y]["validation"]["one_step"], got[y]["validation"]["one_step"])
    # free run: the mixed model (ARX on r fed back to eTS on p, q and back)
    for y in ("p", "q", "r"):
        applied = metrics["outputs"][y]["applied"]
        assert applied["model"] == got[y]["used"]
        _close(applied["validation"]["free_run"], got[y]["validation"]["free_run"])
    # the mixed free run is neither pure eTS nor pure ARX on r
    fits = (metrics["outputs"]["r"]["validation"]["free_run"]["fit"],
            metrics["outputs"]["r"]["arx"]["validation"]["free_run"]["fit"])
    assert got["r"]["validation"]["free_run"]["fit"] not in fits
    assert run.config["model"]["notes"][0] == ("r: ARX, as identify chose (eTS was behind on "
                                               "its validation)")


def test_without_the_block_predict_is_ets_as_before(synthetic, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    table, out, metrics = synthetic
    rules = json.loads((out / "rules.json").read_text())
    del rules["fallback"]
    old = tmp_path / "rules.json"
    old.write_text(json.dumps(rules))
    t0 = metrics["validation"]["t_start"]
    run = predict(table, old, sim_from=t0, segments="all")
    plain = predict(table, out / "rules.json", sim_from=t0, segments="all", fallback=False)
    for y in ("p", "q", "r"):
        got = run.metrics["outputs"][y]
        assert got["used"] == "eTS"
        assert got["validation"] == metrics["outputs"][y]["validation"]  # identify's eTS
        assert plain.metrics["outputs"][y]["validation"] == got["validation"]
    assert not any(n.startswith("r: ") for n in run.config["model"]["notes"])
    assert plain.config["model"]["notes"][0].startswith("eTS on every output (--no-fallback)")


def test_no_change_on_a_real_flight() -> None:
    """The shared ArduCopter 4.0.3 hexa: r is behind no-change (docs/identify.md);
    predict's r one-step is then exactly identify's no-change validation, and its free run
    eTS's (a held value is no simulation)."""
    if not REAL.exists():
        pytest.skip(f"{REAL} not available")
    table = load_for_ident(REAL)
    run = identify(table, IdentConfig(), source=REAL)
    assert run.metrics["outputs"]["r"]["used"] == "no-change"
    assert run.rules["fallback"] == {"r": {"model": "no-change", "reason": (
        "eTS was behind on its validation")}}
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        out = write_run(run, Path(tmp) / "RUN")
        again = predict(load_for_ident(REAL), out, sim_from=run.metrics["validation"]["t_start"])
    got = again.metrics["outputs"]
    assert got["r"]["used"] == "no-change"
    _close(run.metrics["outputs"]["r"]["persistence"]["validation"],
           got["r"]["validation"]["one_step"])
    for y in ("p", "q", "r"):
        _close(run.metrics["outputs"][y]["applied"]["validation"]["free_run"],
               got[y]["validation"]["free_run"])
    # no-change is one-step only: fed back it would hold r at its first value, so the free
    # run is eTS's own on every axis (identify's validation free run)
    for y in ("p", "q", "r"):
        _close(run.metrics["outputs"][y]["validation"]["free_run"],
               got[y]["validation"]["free_run"])
    assert any("one-step only, the free run keeps eTS" in n
               for n in again.config["model"]["notes"])


@pytest.mark.parametrize(("block", "match"), [
    ({"w": {"model": "ARX", "theta": [0.0]}}, r"fallback/w: not an output"),
    ({"r": {"model": "ARX", "theta": [0.0, 1.0]}}, r"fallback/r/theta must be \d+ finite"),
    ({"r": {"model": "ARX"}}, r"theta"),
    ({"r": {"model": "no-change", "theta": [1.0]}}, r"fallback"),
    ({"r": {"model": "median"}}, r"median"),
])
def test_a_bad_block_is_one_clear_error(synthetic, tmp_path: Path, block: dict,  # type: ignore[no-untyped-def]
                                        match: str) -> None:
    table, out, _ = synthetic
    rules = json.loads((out / "rules.json").read_text())
    rules["fallback"] = block
    bad = tmp_path / "rules.json"
    bad.write_text(json.dumps(rules))
    with pytest.raises(IdentError, match=match) as err:
        predict(table, bad)
    assert str(bad) in str(err.value) and "\n" not in str(err.value)


def test_no_change_needs_its_lag_term(synthetic, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from etsid.ident.fallback import read_fallback
    from etsid.ident.regressors import RegressorSpec

    spec = RegressorSpec.parse("p[k-2],u_roll[k-1]", ["p"])
    with pytest.raises(IdentError, match=r"no-change needs the term p\[k-1\]"):
        read_fallback({"fallback": {"p": {"model": "no-change"}}}, spec, "x.json")
    assert read_fallback({}, spec, "x.json") is None


def test_cli_says_it_in_one_line(synthetic, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from etsid.cli import cli

    table, out, _ = synthetic
    saved = tmp_path / "flight.parquet"
    table.to_parquet(saved)
    res = CliRunner().invoke(cli, ["predict", str(saved), "--rules", str(out), "-o",
                                    str(tmp_path / "P"), "--segments", "all"])
    assert res.exit_code == 0, res.output
    assert ("r: ARX, as identify chose (eTS was behind on its validation)"
            in res.output.splitlines())
    metrics = json.loads((tmp_path / "P" / "metrics.json").read_text())
    assert metrics["outputs"]["r"]["used"] == "ARX"
    res = CliRunner().invoke(cli, ["predict", str(saved), "--rules", str(out), "-o",
                                    str(tmp_path / "Q"), "--segments", "all", "--no-fallback"])
    assert res.exit_code == 0, res.output
    metrics = json.loads((tmp_path / "Q" / "metrics.json").read_text())
    assert metrics["outputs"]["r"]["used"] == "eTS"


def test_rules_command_names_the_fall_back(synthetic) -> None:  # type: ignore[no-untyped-def]
    from etsid.cli import cli

    _, out, _ = synthetic
    res = CliRunner().invoke(cli, ["rules", str(out)])
    assert res.exit_code == 0, res.output
    assert res.output.splitlines()[-1] == (
        "fall-back r: ARX, as identify chose (eTS was behind on its validation); "
        "etsid predict applies it, not the rules")
