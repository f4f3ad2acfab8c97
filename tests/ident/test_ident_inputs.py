"""--inputs: sticks, torque commands or rate setpoints, and the auto excitation test."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from etsid.cli import cli
from etsid.errors import IdentError
from etsid.ident.defaults import default_model
from etsid.ident.inputs import STICK_STD_MIN, choose_inputs, kind_of
from etsid.ingest.base import Signal

CUBE = Path(__file__).parents[1] / "data" / "px4_cubeorange_real.ulg"


def _signals(stick_std: float, stick_hz: float = 50.0) -> list[Signal]:
    rng = np.random.default_rng(0)
    t_fast = np.arange(0.0, 10.0, 1 / 250)
    t_rc = np.arange(0.0, 10.0, 1 / stick_hz)
    out = []
    for i, axis in enumerate(("roll", "pitch", "yaw")):
        column = f"u_{axis}"
        out.append(Signal(column, t_rc, rng.normal(0.0, stick_std, t_rc.size),
                          f"manual_control_setpoint.{axis}", 0))
        out.append(Signal(column, t_fast, 0.1 * np.sin(t_fast * (i + 1)),
                          f"actuator_controls_0.control[{i}]", 5))
        out.append(Signal(f"sp_{'pqr'[i]}", t_rc, np.cos(t_rc), f"vehicle_rates_setpoint.{axis}"))
    out.append(Signal("u_thrust", t_fast, np.full(t_fast.size, 0.5),
                      "actuator_controls_0.control[3]", 5))
    return out


def test_flat_sticks_fall_back_to_torque_commands() -> None:
    choice = choose_inputs(_signals(stick_std=0.001))
    assert choice.kind == "torque"
    assert choice.columns == ["u_roll", "u_pitch", "u_yaw", "u_thrust"]
    assert choice.sources["u_roll"] == "actuator_controls_0.control[0]"
    assert "without excitation" in choice.reason
    assert choice.sticks["u_roll"]["std"] < STICK_STD_MIN
    assert choice.signals["u_roll"].source == "actuator_controls_0.control[0]"
    assert "signals" not in choice.to_dict()


def test_excited_sticks_win_and_slow_sticks_do_not() -> None:
    assert choose_inputs(_signals(stick_std=0.2)).kind == "sticks"
    assert choose_inputs(_signals(stick_std=0.2, stick_hz=5.0)).kind == "torque"


def test_explicit_modes_and_missing_family() -> None:
    signals = _signals(stick_std=0.001)
    assert choose_inputs(signals, "sticks").sources["u_yaw"] == "manual_control_setpoint.yaw"
    assert choose_inputs(signals, "setpoints").columns == ["sp_p", "sp_q", "sp_r"]
    no_torque = [s for s in signals if "actuator" not in s.source]
    assert choose_inputs(no_torque).kind == "setpoints"
    with pytest.raises(IdentError, match="no torque"):
        choose_inputs(no_torque, "torque")
    assert kind_of("RATE.ROut") == "torque" and kind_of(None) == "unknown"


def test_table_with_flat_sticks_uses_setpoints() -> None:
    n = 200
    frame = pd.DataFrame({c: np.sin(np.arange(n) * 0.1) for c in
                          ("p", "q", "r", "sp_p", "sp_q", "sp_r")},
                         index=pd.Index(np.arange(n) / 50, name="t"))
    for c in ("u_roll", "u_pitch", "u_yaw"):
        frame[c] = 0.001 * np.sin(np.arange(n))
    frame.attrs["mapping"] = {"u_roll": "manual_control_setpoint.roll"}
    model = default_model(frame)
    assert model.family == "rate setpoints" and "without excitation" in model.reason
    assert default_model(frame, inputs="sticks").family == "loop commands"
    with pytest.raises(IdentError, match="are sticks"):
        default_model(frame, inputs="torque")


def test_real_px4_log_auto_uses_torque_commands(tmp_path: Path) -> None:
    out = tmp_path / "RUN"
    # the land detector says airborne for 1.1 s only (a hop), 0.6 s of it with ground
    # contact: auto refuses in one line
    result = CliRunner().invoke(cli, ["identify", str(CUBE), "--out", str(out), "--quiet"])
    assert result.exit_code == 1
    assert ("no airborne stretch of ≥ 2 s (longest 0.5 s) (land detector + ground contact"
            in result.output)
    result = CliRunner().invoke(cli, ["identify", str(CUBE), "--out", str(out), "--quiet",
                                      "--segments", "all"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert "[torque] from u_roll <- actuator_controls_0.control[0]" in result.output
    config = json.loads((out / "config.json").read_text())
    selection = config["model"]["inputs"]["selection"]
    assert selection["kind"] == "torque" and selection["mode"] == "auto"
    assert selection["sticks"]["u_roll"]["std"] < STICK_STD_MIN
    assert config["input"]["mapping"]["u_pitch"] == "actuator_controls_0.control[1]"
    assert config["model"]["sample_rate"]["factor"] > 1
