"""Vehicle files and scenario settings: valid ones load, invalid ones give one-line errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from etsid.errors import SimError
from etsid.sim import SCENARIOS, Vehicle, list_vehicles, load_vehicle, simulate
from etsid.sim.vehicle import VEHICLE_DIR

TAROT = (VEHICLE_DIR / "tarot680.toml").read_text()


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "broken.toml"
    path.write_text(text)
    return path


def test_packaged_vehicles_load() -> None:
    assert {"tarot680", "quad250"} <= set(list_vehicles())
    hexa = load_vehicle()
    assert isinstance(hexa, Vehicle) and hexa.name == "tarot680" and hexa.n_rotors == 6
    assert load_vehicle(hexa) is hexa
    assert load_vehicle(VEHICLE_DIR / "quad250.toml").n_rotors == 4
    inertia = hexa.inertia
    assert np.allclose(inertia, inertia.T) and np.all(np.linalg.eigvalsh(inertia) > 0)
    mix = hexa.mixer
    assert np.allclose(mix[:, 1:].sum(axis=0), 0.0)  # torque columns balance
    assert np.allclose(hexa.spin.sum(), 0.0)


@pytest.mark.parametrize(
    ("old", "new", "field"),
    [
        ("radius = 0.165", "radius = -0.165", "rotor.radius"),
        ("radius = 0.165", "radius = \"big\"", "rotor.radius"),
        ("radius = 0.165", "", "rotor.radius"),
        ("mass = 4.2 ", "mass = 0.0 ", "mass"),
        ("blades = 2", "blades = 2.5", "rotor.blades"),
        ("ixz = 0.0030", "ixz = true", "inertia.ixz"),
        ('spin = ["cw", "ccw", "cw", "ccw", "ccw", "cw"]', 'spin = ["cw", "ccw"]', "frame.spin"),
        ("model = \"sanchez-cuevas\"", "model = \"magic\"", "ground.model"),
        ("linear = [0.10, 0.10, 0.15]", "linear = [0.1, -0.1, 0.1]", "drag.linear"),
        ("soc0 = 0.95", "soc0 = 1.5", "battery.soc0"),
        ("sag = true", "sag = 1", "battery.sag"),
        ("omega_idle = 80.0", "omega_idle = 900.0", "motor.omega_idle"),
    ],
)
def test_invalid_vehicle_field_names_file_and_field(tmp_path: Path, old: str, new: str,
                                                    field: str) -> None:
    assert old in TAROT
    path = write(tmp_path, TAROT.replace(old, new, 1))
    with pytest.raises(SimError, match=f"broken.toml: field '{field}'") as info:
        load_vehicle(path)
    assert "\n" not in str(info.value)


def test_missing_section_invalid_toml_and_unknown_name(tmp_path: Path) -> None:
    no_motor = TAROT.replace("[motor]", "[motors]")
    with pytest.raises(SimError, match=r"broken.toml: section \[motor\] is missing"):
        load_vehicle(write(tmp_path, no_motor))
    with pytest.raises(SimError, match="broken.toml: invalid TOML"):
        load_vehicle(write(tmp_path, "mass = = 1"))
    with pytest.raises(SimError, match="unknown vehicle 'zeppelin'.*tarot680"):
        load_vehicle("zeppelin")
    with pytest.raises(SimError, match="absent.toml: no such file"):
        load_vehicle(tmp_path / "absent.toml")


def test_scenarios_are_listed_with_descriptions_and_defaults() -> None:
    assert {"hover-ige", "hover-oge", "sine-altitude", "forward-flight"} <= set(SCENARIOS)
    for spec in SCENARIOS.values():
        assert spec["description"] and spec["params"]["duration"] > 0
    assert SCENARIOS["hover-ige"]["params"]["altitude"] < 0.4


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"scenario": "loop-the-loop"}, "unknown scenario 'loop-the-loop'"),
        ({"bogus": 1}, "unknown setting 'bogus'"),
        ({"amplitude": 2.0}, r"setting 'amplitude' must lie in \[0, 1\]"),
        ({"duration": -1.0}, r"setting 'duration' must lie in \(0, 3600\] s"),
        ({"duration": 1e7}, r"setting 'duration' must lie in \(0, 3600\] s"),
        ({"altitude": 1e308}, r"setting 'altitude' must lie in \(0, 1000\] m"),
        ({"excitation": "jazz"}, "setting 'excitation' must be one of"),
        ({"wind": [1, 2]}, "setting 'wind' must be three numbers"),
        ({"throttle": 3}, "setting 'throttle'"),
        ({"alt_hold": "yes"}, "setting 'alt_hold' must be true or false"),
        ({"rate_hz": 0.0}, "rate_hz must be a positive number"),
        ({"seed": -3}, "seed must be a non-negative integer"),
    ],
)
def test_invalid_scenario_settings(kwargs: dict, match: str) -> None:
    args = {"scenario": "hover-oge", "duration": 1.0, **kwargs}
    with pytest.raises(SimError, match=match):
        simulate(**args)


def test_unknown_vehicle_field_is_an_error(tmp_path) -> None:
    """A typo in a vehicle file (cdo for cd0) is refused, not silently ignored."""
    import pytest

    from etsid.errors import SimError
    from etsid.sim import load_vehicle
    from etsid.sim.vehicle import VEHICLE_DIR

    text = (VEHICLE_DIR / "tarot680.toml").read_text().replace("cd0 = ", "cdo = 0.1\ncd0 = ")
    path = tmp_path / "typo.toml"
    path.write_text(text)
    with pytest.raises(SimError, match=r"typo.toml: unknown field\(s\) \[rotor\] cdo"):
        load_vehicle(path)
