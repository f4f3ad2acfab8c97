"""Bad inputs give one-line errors or an `insufficient` answer; gap.json follows its schema."""

from __future__ import annotations

import json

import jsonschema
import pytest
from click.testing import CliRunner

from etsid.cli import cli
from etsid.errors import GapError
from etsid.gap.result import schema, validate
from etsid.gap.run import analyse
from etsid.sim import simulate
from etsid.table import save_table


@pytest.fixture(scope="module")
def hover():
    return simulate("hover-oge", duration=24.0, seed=11, alt_wander=0.3).table


def test_missing_channels_is_an_error(hover) -> None:
    with pytest.raises(GapError, match="lacks .*m1..mN"):
        analyse(hover, hover.drop(columns=[c for c in hover.columns if c.startswith(("m", "u_"))]),
                "sim.parquet", "real.parquet")
    with pytest.raises(GapError, match="real.parquet: lacks az"):
        analyse(hover, hover.drop(columns=["az"]), "sim.parquet", "real.parquet")


def _different(sim, real) -> dict:
    data = analyse(sim, real, "sim.parquet", "real.parquet").data
    assert data["verdict"] == "different-vehicle", data["summary"]
    assert data["effects"] == [] and data["summary"].startswith("Different vehicle:")
    validate(data)
    return data


def test_different_vehicles_is_a_verdict_not_physics(hover) -> None:
    """Another rotor count, or a thrust-to-weight no fault gives (thrust scale 0.35: the
    vehicle needs 2.9× the thrust command): verdict different-vehicle, nothing named."""
    quad = simulate("hover-oge", "quad250", duration=24.0, seed=12).table
    assert "4 motor outputs" in _different(hover, quad)["reason"]
    heavy = simulate("hover-oge", duration=24.0, seed=13,
                     settings={"vehicle.thrust_scale": 0.35}).table
    data = _different(hover, heavy)
    assert "hover thrust" in data["reason"]
    assert data["vehicle_check"]["ratios"]["hover thrust"] > 1.6


def test_tarot_against_quad_is_never_a_confident_name() -> None:
    """Two different vehicles: with motor outputs the motor count differs (different-vehicle);
    with only stick commands (four on both) the pack voltages do (6S against 3S), but a pack
    is a condition of the day, not airframe evidence (issue 39: one octocopter flies 4S and
    3S): the verdict is not consistent and names nothing with confidence."""
    tarot = simulate("hover-oge", "tarot680", duration=30.0, seed=21, alt_wander=0.3).table
    quad = simulate("hover-oge", "quad250", duration=30.0, seed=22, alt_wander=0.3).table
    _different(tarot, quad)

    def sticks_only(t):
        return t.drop(columns=[c for c in t.columns if c[0] == "m" and c[1:].isdigit()])

    for sim, real in ((tarot, quad), (quad, tarot)):
        data = analyse(sticks_only(sim), sticks_only(real), "sim.parquet", "real.parquet").data
        assert data["verdict"] in ("different-vehicle", "mismatch"), data["summary"]
        assert not any("pack voltage" in e for e in data["vehicle_check"]["evidence"])
        assert all(e["confidence"] < 0.5 for e in data["effects"]), data["summary"]


def test_too_little_airborne_data_is_insufficient(hover) -> None:
    short = simulate("hover-oge", duration=9.0, seed=14).table
    data = analyse(hover, short, "sim.parquet", "real.parquet").data
    assert data["verdict"] == "insufficient"
    assert "airborne" in data["reason"] and data["effects"] == []
    validate(data)


def test_schema_rejects_unknown_effect_names() -> None:
    bad = {"schema": "etsid.gap/1", "verdict": "mismatch", "reason": "", "summary": "",
           "sim": {"file": "a", "airborne_s": 1.0}, "real": {"file": "b", "airborne_s": 1.0},
           "mismatch": None, "rmse_before": {}, "rmse_after": {}, "noise": {}, "units": {},
           "effects": [{"name": "gremlins", "parameters": {}, "confidence": 0.5, "evidence": "",
                        "rmse_before": {}, "rmse_after": {}}]}
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, schema())
    with pytest.raises(GapError, match="effects/0/name"):
        validate(bad)


def test_cli_writes_valid_gap_json_and_report(tmp_path, hover) -> None:
    sim_path, real_path = tmp_path / "a.parquet", tmp_path / "b.parquet"
    save_table(hover, sim_path)
    real = simulate("hover-oge", duration=24.0, seed=15, alt_wander=0.3,
                    settings={"vehicle.thrust_scale": 0.85}).table
    save_table(real, real_path)
    out = tmp_path / "gap"
    res = CliRunner().invoke(cli, ["gap", str(sim_path), str(real_path), "--out", str(out),
                                   "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    jsonschema.validate(data, schema())
    assert data["verdict"] == "mismatch"
    assert next(e["name"] for e in data["effects"]) == "thrust_scale"
    scale = data["effects"][0]["parameters"]["scale"]["value"]
    assert scale == pytest.approx(0.85, rel=0.05)
    for name in ("report.md", "index.html", "gap_residual.png", "gap_timeseries.png"):
        assert (out / name).is_file()
    res = CliRunner().invoke(cli, ["gap", str(sim_path), str(tmp_path / "none.parquet"),
                                   "--out", str(out)])
    assert res.exit_code == 1 and res.output.count("\n") == 1 and "etsid: error:" in res.output
