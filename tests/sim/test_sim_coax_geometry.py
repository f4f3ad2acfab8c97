"""Coaxial pairs share an arm angle (an X8 octocopter); three on an arm stay refused."""

from __future__ import annotations

from pathlib import Path

import pytest

from etsid.errors import SimError
from etsid.sim.vehicle import load_vehicle

ROOT = Path(__file__).resolve().parents[2]


def test_the_coaxial_octocopter_loads() -> None:
    vehicle = load_vehicle(ROOT / "benchmarks" / "vehicles" / "octo_coax_from_tarot680.toml")
    assert vehicle.n_rotors == 8


def test_three_rotors_on_one_arm_are_refused() -> None:
    v = load_vehicle("quad250")
    with pytest.raises(SimError, match="more than two rotors on one arm"):
        v.with_settings({"frame.angles_deg": [45.0, 45.0, 45.0, 225.0, 135.0, 315.0],
                         "frame.spin": ["cw", "ccw", "cw", "ccw", "cw", "ccw"]})
