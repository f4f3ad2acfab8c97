"""Issue 22's new vocabulary against its look-alikes, on etsid's simulator with known truth:
a payload is a mass change (roll/pitch authority unchanged), a thrust scale is not; a weak
motor is named with its motor, a steady torque offset is not a weak motor."""

from __future__ import annotations

import pytest

from etsid.gap.run import analyse
from etsid.sim import load_vehicle, simulate

HOVER = dict(scenario="hover-oge", duration=35.0, alt_wander=0.3)


def _gap(settings: dict) -> dict:
    sim = simulate(**HOVER, seed=1).table
    real = simulate(**dict(HOVER, duration=40.0), seed=2, settings=settings).table
    return analyse(sim, real, "sim", "real").data


def _named(data: dict) -> dict[str, dict]:
    return {e["name"]: e for e in data["effects"] if e["name"] != "unexplained"}


def test_a_payload_is_a_mass_change_not_a_thrust_scale() -> None:
    """×1.25 mass: the vertical force drops as for a 0.8 thrust scale, but the moments per
    command do not; a thrust scale would make roll and pitch worse."""
    mass = load_vehicle("tarot680").mass
    data = _gap({"vehicle.mass": 1.25 * mass})
    named = _named(data)
    assert list(named) == ["mass"], data["summary"]
    assert named["mass"]["parameters"]["ratio"]["value"] == pytest.approx(1.25, rel=0.08)
    assert "thrust-to-weight" in data["summary"]


def test_its_look_alike_a_thrust_scale_is_not_named_mass() -> None:
    data = _gap({"vehicle.thrust_scale": 0.85})
    named = _named(data)
    assert list(named) == ["thrust_scale"], data["summary"]
    assert named["thrust_scale"]["parameters"]["scale"]["value"] == pytest.approx(0.85,
                                                                                  abs=0.04)


def test_a_weak_motor_is_named_with_its_motor() -> None:
    """Named first, with its motor and thrust factor."""
    data = _gap({"vehicle.weak_motor": [3, 0.8]})
    assert data["effects"][0]["name"] == "weak_motor", data["summary"]
    p = data["effects"][0]["parameters"]
    assert int(p["motor"]["value"]) == 3
    assert p["scale"]["value"] == pytest.approx(0.8, abs=0.06)


def test_its_look_alike_a_torque_offset_is_not_a_weak_motor() -> None:
    """A constant moment (a CG offset) also shifts the motors' trims, but by the same amount
    whatever the thrust."""
    data = _gap({"vehicle.torque_offset": [0.4, -0.3, 0.0]})
    assert "weak_motor" not in _named(data), data["summary"]
    assert "torque_offset" in _named(data), data["summary"]
