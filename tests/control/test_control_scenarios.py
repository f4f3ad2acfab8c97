"""Scenario references: derivatives, steps, names."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.control.scenarios import SCENARIOS, get_scenario
from etsid.errors import ControlError


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_reference_derivatives_match_finite_differences(name: str) -> None:
    sc = SCENARIOS[name]
    t = np.linspace(0.0, sc.duration, 200_001)
    r, rd, rdd = sc.reference(t)
    dt = t[1] - t[0]
    jumps = np.zeros(t.size, dtype=bool)
    for when in sc.step_times():
        jumps |= np.abs(t - when) < 3 * dt
    ok = ~jumps[1:-1]
    np.testing.assert_allclose(np.gradient(r, dt)[1:-1][ok], rd[1:-1][ok], atol=1e-5)
    np.testing.assert_allclose(np.gradient(rd, dt)[1:-1][ok], rdd[1:-1][ok], atol=5e-4)
    assert r[0] == pytest.approx(sc.start)
    assert rd[0] == 0.0 and rdd[0] == 0.0  # starts from hover: no velocity step


def test_documented_envelopes() -> None:
    t = np.linspace(0.0, 60.0, 60_001)
    assert SCENARIOS["sine-altitude"].reference(t)[0].min() == pytest.approx(1.0, abs=1e-6)
    assert SCENARIOS["sine-altitude"].reference(t)[0].max() == pytest.approx(3.0, abs=1e-6)
    r_ige = SCENARIOS["ige-sine"].reference(t)[0]
    assert r_ige.min() == pytest.approx(0.30, abs=1e-6)
    assert SCENARIOS["hover-ige"].reference(t[t <= 40])[0].max() <= 0.40
    steps = SCENARIOS["altitude-steps"]
    r = steps.reference(np.array([1.9, 2.0, 12.5, 61.0]))[0]
    np.testing.assert_allclose(r, [1.5, 2.5, 1.5, 2.0])
    assert SCENARIOS["mass-change"].mass_change == (30.0, 1.0)


def test_unknown_scenario_is_a_control_error() -> None:
    with pytest.raises(ControlError, match="unknown control scenario 'nope'.*sine"):
        get_scenario("nope")


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_scalar_fast_path_equals_the_vectorised_reference(name: str) -> None:
    sc = SCENARIOS[name]
    t = np.linspace(-0.5, sc.duration + 1.0, 997)
    expected = np.array(sc.reference(t)).T
    got = np.array([sc.at(float(x)) for x in t])
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)
