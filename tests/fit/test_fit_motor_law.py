"""The motor law of the fit (etsid.fit.signals.motor_state) against closed-form answers."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.fit.signals import Flight, motor_state


def _flight(m: np.ndarray, dt: float) -> Flight:
    n = len(m)
    return Flight(source="x", dt=dt, t=np.arange(n) * dt, motors=m, vratio=np.ones(n),
                  gyro=np.zeros((n, 3)), accel=None, vel_body=None,
                  airborne=np.ones(n, dtype=bool), hover=np.ones(n, dtype=bool),
                  motor_rate_hz=1 / dt, gyro_rate_hz=1 / dt)


def test_first_order_hold_is_exact_for_a_ramping_command() -> None:
    # ẋ = (u − x)/τ with u = c t from rest at u = x = 0: x(t) = c (t − τ (1 − e^{−t/τ}))
    dt, tau, c = 0.01, 0.03, 2.0
    t = np.arange(60) * dt
    x = motor_state(_flight((c * t)[:, None] * 0.1, dt), 0.0, tau, 0.0)[:, 0]
    exact = 0.1 * c * (t - tau * (1.0 - np.exp(-t / tau)))
    assert np.max(np.abs(x - exact)) < 1e-12


@pytest.mark.parametrize("delay", [-0.013, -0.004, 0.007, 0.02])
def test_a_delay_of_either_sign_shifts_the_command_by_interpolation(delay: float) -> None:
    dt = 0.01
    t = np.arange(80) * dt
    m = (0.5 + 0.3 * np.sin(7.0 * t))[:, None]
    x = motor_state(_flight(m, dt), 0.0, 0.0, delay)[:, 0]
    inner = slice(5, -5)
    assert np.allclose(x[inner], np.interp(t - delay, t, m[:, 0])[inner], atol=1e-12)
