"""``etsid control`` and ``etsid report`` on a control RUN_DIR, end to end."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from etsid.cli import cli
from etsid.cli.control_cmds import SCENARIO_NAMES
from etsid.control.scenarios import SCENARIOS


def invoke(*args: object):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def test_scenario_names_of_the_cli_are_the_package_scenarios() -> None:
    assert tuple(sorted(SCENARIOS)) == SCENARIO_NAMES


def test_control_writes_run_dir_and_figures_and_report_rerenders_it(tmp_path: Path) -> None:
    out = tmp_path / "RUN"
    res = invoke("control", "sine-altitude", "--out", out, "--duration", 12, "--seed", 2)
    assert res.exit_code == 0, res.output
    assert "ets on sine-altitude, 12 s, stable, tracking RMSE" in res.output
    for name in ("flight.parquet", "metrics.json", "config.json", "rules.json",
                 "history.parquet", "events.parquet"):
        assert (out / name).is_file(), name
    for fig in ("tracking", "potential", "replacements", "thrust"):
        assert (out / "report" / f"{fig}.png").stat().st_size > 5000
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["controller"] == "ets" and metrics["rules_final"] >= 1
    for key in ("tracking_rmse", "max_error", "settling_time", "control_effort",
                "rules_final", "rule_replacements"):
        assert key in metrics
    rules = invoke("rules", out / "rules.json")
    assert rules.exit_code == 0 and "THEN u_thrust =" in rules.output
    (out / "report" / "potential.png").unlink()
    rep = invoke("report", out, "--format", "svg")
    assert rep.exit_code == 0, rep.output
    assert (out / "report" / "potential.svg").is_file()
    page = (out / "report" / "index.html").read_text()
    assert "Fig. 1.12b" in page and "IF h" in page


def test_pid_run_has_no_rule_base_and_steps_have_settling_times(tmp_path: Path) -> None:
    out = tmp_path / "PID"
    res = invoke("control", "step", "--out", out, "--controller", "pid", "--duration", 15)
    assert res.exit_code == 0, res.output  # "step": the former name of altitude-steps
    assert json.loads((out / "config.json").read_text())["scenario"]["name"] == "altitude-steps"
    assert not (out / "rules.json").exists()
    assert sorted(p.stem for p in (out / "report").glob("*.png")) == ["thrust", "tracking"]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["rules_final"] is None and len(metrics["settling_time"]) == 2
    assert all(s is not None and 0 < s < 5 for s in metrics["settling_time"])


def test_default_run_dir_is_named_after_scenario_and_controller(
        tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    res = invoke("control", "hover-ige", "--controller", "pid", "--duration", 2, "--no-report")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "control-hover-ige-pid" / "metrics.json").is_file()
    assert not (tmp_path / "control-hover-ige-pid" / "report").exists()


def test_errors_are_one_line(tmp_path: Path) -> None:
    res = invoke("control", "nope", "--out", tmp_path / "x")
    assert res.exit_code == 2 and "nope" in res.output
    bad = tmp_path / "bad.toml"
    bad.write_text("mass = -1\n")
    res = CliRunner().invoke(cli, ["control", "sine", "--out", str(tmp_path / "y"),
                                   "--vehicle", str(bad)])
    assert res.exit_code == 1 and res.output.startswith("etsid: error: ")
    assert len(res.output.strip().splitlines()) == 1
    res = CliRunner().invoke(cli, ["report", str(tmp_path / "missing")])
    assert res.exit_code == 1
