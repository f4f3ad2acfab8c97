"""``etsid fit`` against the simulator's known parameters, and its vehicle file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from etsid.cli import cli
from etsid.fit import fit_tables
from etsid.fit.output import write_fit
from etsid.fit.truth import vehicle_truth
from etsid.sim import simulate
from etsid.sim.vehicle import load_vehicle


@pytest.fixture(scope="module")
def flight() -> pd.DataFrame:
    return simulate("sine-altitude", vehicle="quad250", duration=30, seed=11,
                    settings={"scenario.altitude": 4.0, "scenario.alt_amplitude": 1.5,
                              "scenario.amplitude": 0.25}).table


@pytest.fixture(scope="module")
def result(flight: pd.DataFrame):
    return fit_tables([flight])


def test_identifiable_parameters_match_the_vehicle_file(result) -> None:
    truth = vehicle_truth(load_vehicle("quad250"), result.layout["v0"])
    p = result.params
    assert p["hover_command"].value == pytest.approx(truth["hover_command"], rel=0.02)
    assert p["thrust_to_weight"].value == pytest.approx(truth["thrust_to_weight"], rel=0.05)
    assert p["motor_time_constant"].value == pytest.approx(truth["motor_time_constant"],
                                                           rel=0.2)
    assert p["time_delay"].value < 0.006
    for axis in ("roll", "pitch"):
        assert p[f"{axis}_effectiveness"].value == pytest.approx(
            truth[f"{axis}_effectiveness"], rel=0.1)
    assert result.layout["arm_known"] and result.layout["n"] == 4


def test_what_logs_cannot_separate_is_declared_not_fitted(result) -> None:
    for name in ("mass", "kappa_q"):
        assert result.params[name].verdict == "unidentifiable"
        assert not np.isfinite(result.params[name].se)


def test_vehicle_file_loads_back_and_carries_the_fitted_combinations(result, tmp_path: Path
                                                                    ) -> None:
    path, json_path = write_fit(result, tmp_path / "fitted.toml")
    vehicle = load_vehicle(path)
    again = vehicle_truth(vehicle, result.layout["v0"])
    p = result.params
    assert again["roll_effectiveness"] == pytest.approx(p["roll_effectiveness"].value,
                                                        rel=1e-3)
    assert again["thrust_to_weight"] == pytest.approx(p["thrust_to_weight"].value, rel=0.01)
    assert again["motor_time_constant"] == pytest.approx(p["motor_time_constant"].value,
                                                         rel=1e-4)
    text = path.read_text()
    assert "roll_effectiveness" in text and "unidentifiable" in text
    assert json_path.exists()


def test_cli_refuses_a_table_without_motor_outputs_in_one_line(flight: pd.DataFrame,
                                                               tmp_path: Path) -> None:
    bare = flight.drop(columns=[c for c in flight if c.startswith("m") and c[1:].isdigit()])
    src = tmp_path / "no_motors.parquet"
    bare.to_parquet(src)
    res = CliRunner().invoke(cli, ["fit", str(src), "-o", str(tmp_path / "v.toml")])
    assert res.exit_code == 1
    assert "no_motors" in res.output and "active motor output" in res.output
    assert "Traceback" not in res.output
