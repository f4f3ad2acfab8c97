"""Drag fit: the rotors' H-force scales with rotor speed, which falls in forward flight."""

from __future__ import annotations

import numpy as np

from etsid.fit.drag import fit_drag
from etsid.fit.signals import Flight

D_BODY, D_ROTOR, E_QUAD = 0.04, 0.13, 0.018
"""Truth (per mass): body linear drag 1/s, H-force at hover rotor speed 1/s, quadratic 1/m
(the proportions of quad250)."""


def _flight(rng: np.random.Generator, cruise: float, noise: float) -> tuple[Flight, np.ndarray]:
    """A forward flight at 250 Hz: hover, an 8 s ramp to ``cruise`` m/s, a wandering hold;
    rotor speed over hover s = 1 − 0.0015 v² (translational lift: −4 % at 5 m/s)."""
    dt = 0.004
    t = np.arange(0.0, 60.0, dt)
    v = cruise * np.clip((t - 5.0) / 8.0, 0.0, 1.0)
    wander = np.cumsum(rng.normal(0.0, 0.02, t.size))
    v = v + 0.3 * np.sin(0.7 * t) + 0.05 * (wander - np.linspace(0, wander[-1], t.size))
    s = 1.0 - 0.0015 * v ** 2
    a = -(D_BODY + D_ROTOR * s) * v - E_QUAD * np.abs(v) * v + rng.normal(0.0, noise, t.size)
    zeros = np.zeros((t.size, 3))
    side = 0.2 * np.sin(0.9 * t)   # the y axis: a small sway, pure linear drag
    accel = np.column_stack([a, -D_BODY * side + rng.normal(0.0, noise, t.size), zeros[:, 0]])
    vel = np.column_stack([v, side, zeros[:, 0]])
    n = t.size
    f = Flight(source="synthetic", dt=dt, t=t, motors=np.full((n, 4), 0.5),
               vratio=np.ones(n), gyro=zeros, accel=accel, vel_body=vel,
               airborne=np.ones(n, dtype=bool), hover=np.zeros(n, dtype=bool),
               motor_rate_hz=250.0, gyro_rate_hz=250.0)
    return f, s


def test_rotor_speed_column_removes_the_h_force_bias_the_lumped_fit_hides() -> None:
    """Lumped (s = 1), the linear coefficient comes out high and the quadratic low by more
    than their intervals say; with the (s − 1) v column both intervals cover the truth
    about 95 % of the time."""
    n_rep = 40
    hit_lumped = np.zeros(2)
    hit_speed = np.zeros(2)
    truth = np.array([D_BODY + D_ROTOR, E_QUAD])
    for seed in range(n_rep):
        rng = np.random.default_rng(seed)
        f, s = _flight(rng, 5.0 + seed % 3, 0.05)
        for speeds, hits in ((None, hit_lumped), ([s], hit_speed)):
            fit = fit_drag([f], speeds)
            assert fit is not None
            x = fit["x"]
            hits += np.abs(-x.coef[:2] - truth) <= 1.96 * x.se[:2]
    assert np.all(hit_speed / n_rep >= 0.85), hit_speed
    assert np.all(hit_lumped / n_rep <= 0.3), hit_lumped


def test_without_rotor_speed_change_the_column_changes_nothing_material() -> None:
    """Rotors at hover speed throughout (s ≡ 1 + tiny noise): the fit with the column
    recovers the same drag as the lumped one."""
    rng = np.random.default_rng(7)
    f, _ = _flight(rng, 5.0, 0.1)
    v = f.vel_body[:, 0]
    f.accel[:, 0] = -(D_BODY + D_ROTOR) * v - E_QUAD * np.abs(v) * v + rng.normal(0, 0.1, v.size)
    s = 1.0 + 1e-3 * rng.normal(size=v.size)
    a = fit_drag([f])
    b = fit_drag([f], [s])
    assert a is not None and b is not None
    assert abs(a["x"].coef[0] - b["x"].coef[0]) < 2 * a["x"].se[0]
    assert abs(-b["x"].coef[0] - (D_BODY + D_ROTOR)) < 3 * b["x"].se[0]
