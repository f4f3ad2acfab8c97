"""The battery law slows the rotors' spin-up with them: thrust and reaction torque follow
``(V/V_sim)^n`` (∝ Ω²), so the rotor speed and the yaw reaction of its spin-up follow the
square root (a known answer on the regressors themselves)."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.gap.candidates import BY_NAME, Context
from etsid.gap.nominal import Mods, features, fit_nominal
from etsid.gap.signals import prepare
from etsid.sim import simulate


@pytest.fixture(scope="module")
def flight():
    table = simulate("hover-oge", "quad250", duration=20.0, seed=5, alt_wander=0.3,
                     amplitude=0.4).table
    return prepare(table, "SIM")


def test_a_rotor_speed_factor_scales_the_spin_up_columns_alone(flight):
    nominal = fit_nominal(flight)
    n_rotors = flight.motors.shape[1]
    base = features(flight, nominal.k, nominal.tau, Mods(), ("r",), nominal.delay,
                    nominal.v_ref)["r"]
    gain = np.linspace(0.8, 1.0, flight.n)
    slow = features(flight, nominal.k, nominal.tau, Mods(spin_gain=gain), ("r",),
                    nominal.delay, nominal.v_ref)["r"]
    torque, spin = slice(0, n_rotors), slice(n_rotors, 2 * n_rotors)
    assert np.array_equal(slow[:, torque], base[:, torque])
    assert np.allclose(slow[:, spin], base[:, spin] * gain[:, None])
    assert np.array_equal(slow[:, 2 * n_rotors:], base[:, 2 * n_rotors:])


def test_the_battery_law_gives_the_rotors_the_square_root_of_its_thrust_factor(flight):
    sag = BY_NAME["battery_sag"]
    ctx = Context(flight, fit_nominal(flight), float(np.mean(flight.vbat)) * 1.1, None, None)
    mods = sag.build(np.array([2.0]), ctx)
    assert np.allclose(mods.thrust_gain, mods.torque_gain)
    assert np.allclose(mods.spin_gain, np.sqrt(mods.thrust_gain))
    assert np.all(mods.spin_gain < 1.0)  # a pack below SIM's voltage slows the rotors
