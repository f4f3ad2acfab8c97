"""Optional vehicle effects and the one settings mechanism (TOML, --set, Python API)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from etsid.errors import SimError
from etsid.sim import load_vehicle, simulate
from etsid.sim.settings import split_settings
from etsid.sim.vehicle import EFFECTS, VEHICLE_DIR

TAROT = (VEHICLE_DIR / "tarot680.toml").read_text()
NEUTRAL = """
[effects]
time_delay = 0.0
motor_lag = [0.05, 0.05]
thrust_scale = 1.0
torque_scale = 1.0
cg_offset = [0.0, 0.0, 0.0]
torque_offset = [0.0, 0.0, 0.0]
inertia_scale = 1.0
accel_bias = [0.0, 0.0, 0.0]
estimator = "none"
ground_effect_torque = false
"""


def test_vehicle_files_without_effects_get_neutral_defaults() -> None:
    fx = load_vehicle("quad250").effects
    assert set(fx) == set(EFFECTS)
    assert fx["thrust_scale"] == 1.0 and fx["time_delay"] == 0.0 and fx["motor_lag"] is None
    assert fx["gyro_bias"] is None and fx["estimator"] == "none"
    # defaults are copies, not shared lists
    fx["cg_offset"][0] = 9.0
    assert load_vehicle("tarot680").effects["cg_offset"] == [0.0, 0.0, 0.0]


def test_neutral_effects_fly_bit_identical(tmp_path: Path) -> None:
    path = tmp_path / "neutral.toml"
    path.write_text(TAROT + NEUTRAL)
    a = simulate("hover-ige", duration=2.0, seed=4)
    b = simulate("hover-ige", vehicle=path, duration=2.0, seed=4)
    assert np.array_equal(a.table.to_numpy(), b.table.to_numpy())
    assert np.array_equal(a.truth.to_numpy(), b.truth.to_numpy())


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("thrust_scale = 0.0", r"field 'effects.thrust_scale' must lie in \[0.05, 20\]"),
        ("thrust_scale = 1e300", r"field 'effects.thrust_scale' must lie in \[0.05, 20\]"),
        ("motor_lag = [0.05]", "field 'effects.motor_lag' must be a list of two numbers"),
        ("motor_lag = [0.05, 1e-300]", "field 'effects.motor_lag' two numbers in"),
        ("cg_offset = [0.01, 0.0]", "field 'effects.cg_offset' must be a list of three"),
        ("estimator = \"kalman\"", "field 'effects.estimator' must be one of none, mahony"),
        ("time_delay = -0.01", r"field 'effects.time_delay' must lie in \[0, 1\] s"),
        ("time_delay = 1e9", r"field 'effects.time_delay' must lie in \[0, 1\] s"),
        ("inertia_scale = [1.0, 0.0, 1.0]", "field 'effects.inertia_scale'"),
        ("thrust_scal = 1.1", r"unknown field\(s\) \[effects\] thrust_scal"),
    ],
)
def test_invalid_effects_name_file_and_field(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "fx.toml"
    path.write_text(TAROT + f"\n[effects]\n{text}\n")
    with pytest.raises(SimError, match=f"fx.toml: {match}") as info:
        load_vehicle(path)
    assert "\n" not in str(info.value)


def test_with_settings_reaches_effects_sections_and_aliases() -> None:
    base = load_vehicle()
    v = base.with_settings({"thrust_scale": 1.1, "effects.time_delay": 0.02, "mass": 4.5,
                            "rotor.radius": 0.17, "battery_sag": False})
    assert v.effects["thrust_scale"] == 1.1 and v.effects["time_delay"] == 0.02
    assert v.mass == 4.5 and v["rotor"]["radius"] == 0.17 and v["battery"]["sag"] is False
    assert base.effects["thrust_scale"] == 1.0 and base.mass == 4.2  # the original is intact
    with pytest.raises(SimError, match="unknown vehicle setting 'rotor.radios'"):
        base.with_settings({"rotor.radios": 0.2})
    with pytest.raises(SimError, match=r"field 'mass' must lie in \[0.005, 500\] kg"):
        base.with_settings({"mass": -1})


def test_split_settings_and_simulate_settings() -> None:
    assert split_settings({"vehicle.mass": 5, "scenario.altitude": 2.0}) == (
        {"mass": 5}, {"altitude": 2.0})
    for bad in ("altitude", "pilot.kv", "vehicle."):
        with pytest.raises(SimError, match="starts with 'vehicle.' or 'scenario.'"):
            split_settings({bad: 1})
    with pytest.raises(SimError, match="unknown vehicle setting 'trust_scale'"):
        simulate("hover-oge", duration=1.0, settings={"vehicle.trust_scale": 1.1})
    flight = simulate("hover-oge", settings={"scenario.duration": 1.0, "vehicle.mass": 4.0,
                                             "scenario.altitude": 2.0})
    assert flight.vehicle.mass == 4.0 and flight.params["altitude"] == 2.0
    assert flight.table.index[-1] == pytest.approx(1.0 - 1 / 250)


def test_physics_page_shows_the_declared_ranges() -> None:
    from etsid.sim.vehicle_params import ranges_markdown

    page = (Path(__file__).resolve().parents[2] / "docs" / "physics.md").read_text("utf-8")
    assert ranges_markdown() in page, "docs/physics.md: paste ranges_markdown() again"


def _numeric_fields() -> list[tuple[str, float]]:
    from etsid.sim.vehicle_params import EFFECTS, VEHICLE

    out = [(f"{s}.{n}" if s else n, p.high) for s, fields in VEHICLE.items()
           for n, p in fields.items() if p.kind == "num"]
    return out + [(f"effects.{n}", p.high) for n, p in EFFECTS.items() if p.kind == "num"]


@pytest.mark.parametrize(("key", "high"), _numeric_fields())
def test_every_numeric_setting_is_refused_beyond_its_range(key: str, high: float) -> None:
    base = load_vehicle("tarot680")
    for value in (high * 10 + 1, float("inf"), float("nan")):
        with pytest.raises(SimError, match=f"field '{key}' must"):
            base.with_settings({key: value})
