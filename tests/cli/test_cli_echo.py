"""Commands say what they applied: ``etsid simulate --set`` echoes the settings it used."""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner

from etsid.cli import cli


def test_simulate_echoes_the_applied_settings(tmp_path: Path) -> None:
    result = CliRunner().invoke(cli, ["simulate", "hover-ige", "-o", str(tmp_path / "f.parquet"),
                                      "--duration", "1", "--set", "vehicle.thrust_scale=1.1",
                                      "--set", "vehicle.motor_lag=[0.04,0.08]",
                                      "--set", "scenario.altitude=0.3"])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[-1] == (
        "settings applied: vehicle.thrust_scale = 1.1, vehicle.motor_lag = [0.04, 0.08], "
        "scenario.altitude = 0.3")
    plain = CliRunner().invoke(cli, ["simulate", "hover-ige", "-o", str(tmp_path / "g.parquet"),
                                     "--duration", "1"])
    assert plain.exit_code == 0 and "settings applied" not in plain.output
