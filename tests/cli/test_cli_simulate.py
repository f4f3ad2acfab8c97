"""``etsid simulate --set`` and ``--replay``: settings reach the model, bad input is one line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from etsid.cli import cli
from etsid.cli.settings import parse_value
from etsid.sim import simulate


def test_cli_set_changes_vehicle_and_scenario(tmp_path: Path) -> None:
    out = tmp_path / "f.parquet"
    result = CliRunner().invoke(cli, ["simulate", "hover-oge", "-o", str(out),
                                      "--set", "scenario.duration=1.0",
                                      "--set", "scenario.altitude=2.5",
                                      "--set", "vehicle.thrust_scale=1.2"])
    assert result.exit_code == 0, result.output
    table = pd.read_parquet(out)
    assert len(table) == 250
    assert table["true_alt"].iloc[0] == pytest.approx(2.5)
    # 20 % more thrust per rotor speed: hovers at 1/sqrt(1.2) of the nominal rotor speed
    nominal = simulate("hover-oge", duration=1.0, altitude=2.5).truth["true_w1"].iloc[0]
    assert table["true_w1"].iloc[0] == pytest.approx(nominal / np.sqrt(1.2), rel=1e-9)


@pytest.mark.parametrize(
    ("item", "code", "words"),
    [
        ("vehicle.thrust_scal=1.1", 1, ["unknown vehicle setting 'thrust_scal'"]),
        ("vehicle.thrust_scale=-1", 1, ["effects.thrust_scale", "must lie in [0.05, 20]"]),
        ("scenario.altitud=1", 1, ["unknown setting 'altitud'"]),
        ("altitude=1", 1, ["'vehicle.' or 'scenario.'"]),
        ("vehicle.cg_offset", 2, ["expected KEY=VALUE"]),
        ("vehicle.cg_offset=[0.1,", 2, ["vehicle.cg_offset", "is not a number"]),
    ],
)
def test_cli_set_errors_are_one_line(tmp_path: Path, item: str, code: int,
                                     words: list[str]) -> None:
    result = CliRunner().invoke(cli, ["simulate", "hover-oge", "--duration", "0.5",
                                      "-o", str(tmp_path / "f.parquet"), "--set", item])
    assert result.exit_code == code
    err = result.stderr.strip()
    assert "Traceback" not in err
    for word in words:
        assert word in err.splitlines()[-1]
    assert not (tmp_path / "f.parquet").exists()


def test_cli_replay_writes_the_twin(tmp_path: Path) -> None:
    log = tmp_path / "flight.parquet"
    runner = CliRunner()
    result = runner.invoke(cli, ["simulate", "hover-oge", "--duration", "4", "-o", str(log)])
    assert result.exit_code == 0, result.output
    out = tmp_path / "twin.parquet"
    result = runner.invoke(cli, ["simulate", "--replay", str(log), "-o", str(out),
                                 "--thrust", "alt-hold", "--set", "vehicle.thrust_scale=1.0"])
    assert result.exit_code == 0, result.output
    assert "twin of" in result.output and "controller: vehicle file" in result.output
    twin = pd.read_parquet(out)
    original = pd.read_parquet(log)
    assert len(twin) == len(original)
    d = twin["true_p"] - original["true_p"]
    assert math.sqrt(float(np.mean(d**2))) < 0.01  # rad/s
    result = runner.invoke(cli, ["simulate", "hover-oge", "--replay", str(log), "-o",
                                 str(out)])
    assert result.exit_code == 2 and "either SCENARIO or --replay" in result.output
    result = runner.invoke(cli, ["simulate", "--replay", str(log), "-o", str(out), "--set",
                                 "scenario.duration=2"])
    assert result.exit_code == 1 and "vehicle settings only" in result.stderr


@pytest.mark.parametrize("opt", [["--duration", "3"], ["--rate", "100"]])
def test_cli_replay_refuses_scenario_options(tmp_path: Path, opt: list[str]) -> None:
    log = tmp_path / "flight.parquet"
    assert CliRunner().invoke(cli, ["simulate", "hover-oge", "--duration", "1", "-o",
                                    str(log)]).exit_code == 0
    result = CliRunner().invoke(cli, ["simulate", "--replay", str(log), "-o",
                                      str(tmp_path / "t.parquet"), *opt])
    assert result.exit_code == 2 and f"{opt[0]} does not apply to --replay" in result.output


def test_parse_value_uses_toml_and_bare_words() -> None:
    assert parse_value("0.02") == 0.02 and parse_value("[0.02, 0, 0]") == [0.02, 0, 0]
    assert parse_value("false") is False and parse_value("mahony") == "mahony"
    assert parse_value('"a b"') == "a b"
    with pytest.raises(ValueError, match="is not a number"):
        parse_value("[1,")


def test_cli_replay_refuses_a_non_finite_twin(tmp_path: Path) -> None:
    """A recorded vz of 1e200 m/s as the twin's initial state: the physics overflows; the
    twin is refused in one line naming the first channel and time, and nothing is written
    (the same log with its vz as recorded gives a finite twin)."""
    log = tmp_path / "flight.parquet"
    runner = CliRunner()
    result = runner.invoke(cli, ["simulate", "hover-oge", "--duration", "2", "-o", str(log)])
    assert result.exit_code == 0, result.output
    out = tmp_path / "twin.parquet"
    result = runner.invoke(cli, ["simulate", "--replay", str(log), "-o", str(out)])
    assert result.exit_code == 0 and out.exists(), result.output
    out.unlink()
    table = pd.read_parquet(log)
    table["vz"] = 1e200
    table.to_parquet(log)
    result = runner.invoke(cli, ["simulate", "--replay", str(log), "-o", str(out)])
    assert result.exit_code == 1, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr
    assert "replay twin" in lines[0] and "is not finite from t = 0.000 s" in lines[0]
    assert lines[0].split("left the physics' domain: ")[1].split(" ")[0] in table.columns
    assert not out.exists()
