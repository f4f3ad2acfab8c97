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


def _governed_form():
    from etsid.gap.candidates import LIBRARY, _battery
    forms = [c for c in LIBRARY if c.name == "battery_sag"]
    assert len(forms) == 2 and forms[0].build is _battery
    return forms[1]


def test_an_esc_that_holds_its_idle_speed_scales_only_the_commanded_part(flight):
    """The second form: Ω_i ∝ k + m_i (V/V_sim)^(n/2) over k + m_i, so a rotor at zero
    command keeps its speed, and with no idle offset it is the first form."""
    governed = _governed_form()
    nominal = fit_nominal(flight)
    v_sim = float(np.mean(flight.vbat)) * 1.1
    ctx = Context(flight, nominal, v_sim, None, None)
    mods = governed.build(np.array([2.0]), ctx)
    g = flight.vbat / v_sim
    m = np.clip(flight.motors, 0.0, 1.0)
    ratio = (nominal.k + m * g[:, None]) / (nominal.k + m)
    assert nominal.k > 0.0
    assert np.allclose(mods.spin_gain, ratio)
    assert np.allclose(mods.thrust_gain, ratio ** 2)
    assert np.allclose(mods.torque_gain, ratio ** 2)
    # between the held idle (1) and the whole speed following the pack (g)
    assert np.all(mods.spin_gain <= 1.0) and np.all(mods.spin_gain >= g[:, None] - 1e-12)
    nominal.k = 0.0
    no_idle = governed.build(np.array([2.0]), ctx)
    plain = BY_NAME["battery_sag"].build(np.array([2.0]), ctx)
    assert np.allclose(no_idle.thrust_gain, np.asarray(plain.thrust_gain)[:, None]
                       * np.ones_like(m))


def test_the_held_idle_form_needs_motor_outputs(flight):
    from dataclasses import replace
    governed = _governed_form()
    ctx = Context(flight, fit_nominal(flight), float(np.mean(flight.vbat)), None, None)
    assert governed.available(ctx)
    sticks = replace(ctx, flight=replace(flight, inputs="sticks"))
    assert not governed.available(sticks)
