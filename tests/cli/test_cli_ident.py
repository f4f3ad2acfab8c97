"""CLI end to end: identify, predict, rules, report; help on every command; errors."""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

import click
import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from etsid.cli import COMMAND_MODULES, cli
from etsid.ident import IdentConfig, identify, read_run
from etsid.ident.synthetic import rate_table
from etsid.table import save_table

DATA = Path(__file__).parents[1] / "data"
DOCS = Path(__file__).parents[2] / "docs"


def invoke(*args: str) -> object:
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def saved_table(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return save_table(rate_table(2000, seed=7), tmp_path_factory.mktemp("t") / "flight.parquet")


@pytest.fixture(scope="module")
def run_dir(saved_table: Path) -> Path:
    out = saved_table.parent / "RUN"
    result = invoke("identify", saved_table, "--out", out, "--quiet")
    assert result.exit_code == 0, result.output
    assert "inputs: loop commands (u_roll, u_pitch, u_yaw, u_thrust)" in result.output
    assert re.search(r"\nrules: \d+ in rules.json \(saved at the end of the learning "
                     r"part\); while learning: at most \d+, \d+ at the end of the flight",
                     result.output)
    assert "rule → regime" in result.output and "\nlearnt: " in result.output
    return out


def test_box_jenkins_cli_equals_python_api(tmp_path: Path) -> None:
    out = tmp_path / "bj"
    result = invoke("identify", DATA / "gas_furnace.csv", "--output", "co2", "--regressors",
                    "co2[k-1],input_gas_rate[k-4]", "--out", out, "--json")
    assert result.exit_code == 0, result.output
    printed = json.loads(result.stdout)  # notes go to stderr
    frame = pd.read_csv(DATA / "gas_furnace.csv")
    frame.index = pd.Index(np.arange(len(frame), dtype=float), name="t")
    api = identify(frame, IdentConfig(outputs=["co2"],
                                      regressors="co2[k-1],input_gas_rate[k-4]"))
    assert printed["outputs"] == api.metrics["outputs"]
    assert printed == json.loads((out / "metrics.json").read_text())
    assert printed["n_samples"] == 292
    config = json.loads((out / "config.json").read_text())
    assert len(config["input"]["sha256"]) == 64
    assert config["model"]["regressors"] == "co2[k-1],input_gas_rate[k-4]"


def test_normalise_option_is_stored(tmp_path: Path) -> None:
    # Box–Jenkins: running ranges reproduce the eTS-core numbers of docs/identify.md,
    # learning-part ranges (the default) give one rule there at radius 2
    args = [DATA / "gas_furnace.csv", "--output", "co2", "--regressors",
            "co2[k-1],input_gas_rate[k-4]", "--validate", "0", "--json", "--quiet"]
    runs = {}
    for mode in ("running", "learn"):
        out = tmp_path / mode
        result = invoke("identify", *args, "--out", out, "--normalise", mode)
        assert result.exit_code == 0, result.output
        runs[mode] = json.loads(result.stdout)
        config = json.loads((out / "config.json").read_text())
        assert config["parameters"]["normalise"] == mode
        rules = json.loads((out / "rules.json").read_text())
        assert (rules["params"]["x_range"] is None) == (mode == "running")
    assert runs["running"]["outputs"]["co2"]["online"]["rmse"] == pytest.approx(0.4309,
                                                                                 abs=5e-5)
    assert runs["running"]["rules"]["final"] == 2
    assert runs["learn"]["outputs"]["co2"]["online"]["rmse"] == pytest.approx(0.4375,
                                                                               abs=5e-5)
    assert runs["learn"]["rules"]["final"] == 1


def test_identify_writes_the_file_contract(run_dir: Path) -> None:
    for name in ("predictions.parquet", "history.parquet", "rules.json", "metrics.json",
                 "config.json"):
        assert (run_dir / name).stat().st_size > 0
    metrics = json.loads((run_dir / "metrics.json").read_text())
    # 250 Hz table identified at 50 Hz: blocks of 5, white-noise floor σ/√5
    assert metrics["sample_rate"]["factor"] == 5 and metrics["sample_rate"]["rate_hz"] == 50
    assert metrics["outputs"]["p"]["noise_std_native"] == 0.01
    assert metrics["outputs"]["p"]["noise_std"] == pytest.approx(0.01 / np.sqrt(5))
    # 8 s of data: 272 learning rows for 37 parameters per rule; a loose bound only
    assert metrics["outputs"]["p"]["validation"]["one_step"]["ndei"] < 0.5
    rules = json.loads((run_dir / "rules.json").read_text())
    assert rules["regressors"]["sample_rate_hz"] == 50


def test_predict_cli_reproduces_validation(run_dir: Path, saved_table: Path,
                                           tmp_path: Path) -> None:
    ident = read_run(run_dir)
    t0 = ident.metrics["validation"]["t_start"]
    out = tmp_path / "P"
    # eTS on every output: identify's y_val / y_sim columns are the eTS model's (the
    # fall-back identify may save is tested in tests/ident/test_ident_fallback.py)
    result = invoke("predict", saved_table, "--rules", run_dir / "rules.json", "--out", out,
                    "--sim-from", repr(t0), "--quiet", "--no-fallback")
    assert result.exit_code == 0, result.output
    pred = read_run(out).predictions
    val = ident.predictions["part"] == "validation"
    np.testing.assert_array_equal(pred.loc[val, "q_hat"], ident.predictions.loc[val, "q_val"])
    np.testing.assert_array_equal(pred["r_sim"], ident.predictions["r_sim"])
    learn = invoke("predict", saved_table, "--rules", run_dir, "--out", tmp_path / "L",
                   "--learn", "--json", "--quiet")
    assert json.loads(learn.output)["rules"]["final"] >= 1


def test_rules_cli(run_dir: Path) -> None:
    text = invoke("rules", run_dir).output
    assert "IF" in text and "THEN" in text and "p[k-1]" in text
    raw = json.loads(invoke("rules", run_dir / "rules.json", "--json").output)
    assert raw["schema"] == "etsid.rules/2" and "regressors" in raw


def test_report_cli(run_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import etsid.report.build as build

    # two of the five figures keep the test fast; tests/test_report.py draws all five
    keep = {k: build.FIGURES[k] for k in ("rates", "structure")}
    monkeypatch.setattr(build, "FIGURES", keep)
    result = invoke("report", run_dir)
    assert result.exit_code == 0, result.output
    html = (run_dir / "report" / "index.html").read_text()
    assert html.count("data:image/png;base64,") == 2 and "THEN" in html
    assert (run_dir / "report" / "report.md").stat().st_size > 1000


@pytest.mark.parametrize(("args", "message"), [
    (["--output", "co2"], "--output needs --regressors"),
    (["--output", "nope", "--regressors", "nope[k-1]"], "missing column(s) nope"),
    (["--output", "co2", "--regressors", "co2[k+1]"], "bad regressor"),
])
def test_one_line_errors(args: list[str], message: str, tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["identify", str(DATA / "gas_furnace.csv"), "--out",
                                      str(tmp_path / "x"), *args])
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("etsid: error:") and message in lines[0]


def test_vehicle_sets_the_regime_bands(tmp_path: Path) -> None:
    table = rate_table(1500, seed=8)
    table["alt"] = np.where(np.arange(len(table)) < 700, 0.1, 1.0)
    saved_table = save_table(table, tmp_path / "alt.parquet")
    result = invoke("identify", saved_table, "--out", tmp_path / "v", "--quiet",
                    "--vehicle", "quad250")
    assert result.exit_code == 0, result.output
    regimes = json.loads((tmp_path / "v" / "metrics.json").read_text())["regimes"]
    assert regimes["basis"] == "z/R" and regimes["rotor_radius_m"] == 0.0635
    result = CliRunner().invoke(cli, ["identify", str(saved_table), "--out",
                                      str(tmp_path / "w"), "--vehicle", "nope"])
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "unknown vehicle 'nope'" in lines[0]


def test_usage_errors_exit_2(tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["identify", str(DATA / "gas_furnace.csv"), "--out",
                                      str(tmp_path), "--validate", "1.5"])
    assert result.exit_code == 2
    result = CliRunner().invoke(cli, ["report", str(tmp_path), "--format", "gif"])
    assert result.exit_code == 2
    result = CliRunner().invoke(cli, ["rules", str(tmp_path / "none.json")])
    assert result.exit_code == 1 and "no such rule-base file" in result.output


def test_every_command_has_help() -> None:
    # list through the group: commands load lazily, so cli.commands is empty after import
    ctx = click.Context(cli, info_name="etsid")
    names = cli.list_commands(ctx)
    assert set(names) == set(COMMAND_MODULES) and len(names) >= 7, names
    for name in names:
        command = cli.get_command(ctx, name)
        assert command is not None and command.name == name, name
        result = CliRunner().invoke(cli, [name, "--help"], prog_name="etsid")
        assert result.exit_code == 0, (name, result.output)
        assert result.output.startswith(f"Usage: etsid {name} "), result.output
        assert command.help and len(command.help.strip()) > 20, name
        for param in command.params:
            if isinstance(param, click.Option):
                assert param.help, f"{name} {param.opts} has no help"


def test_cli_md_is_current() -> None:
    spec = importlib.util.spec_from_file_location("make_cli_md", DOCS / "make_cli_md.py")
    module = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    text = module.render()
    for name in ("identify", "predict", "rules", "report"):
        assert f"## etsid {name}" in text
    # only this package's commands: other sections belong to other maintainers
    current = (DOCS / "cli.md").read_text()
    for name in ("identify", "predict", "rules", "report"):
        section = text.split(f"## etsid {name}\n")[1].split("## etsid")[0]
        assert section in current, f"docs/cli.md is stale for {name}: run docs/make_cli_md.py"
