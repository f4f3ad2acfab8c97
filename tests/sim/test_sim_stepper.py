"""Stepping API: the full state really is full, commands reach the right place."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.errors import SimError
from etsid.sim import hover_trim, load_vehicle
from etsid.sim.body import euler_to_quat
from etsid.sim.estimator import EST_F, N_EST, mahony_reference, mahony_step
from etsid.sim.stepper import Simulator

EFFECTS = {"time_delay": 0.0125, "motor_lag": [0.04, 0.07], "estimator": "mahony",
           "gyro_bias": [0.01, 0.0, -0.01], "cg_offset": [0.01, 0.0, 0.0]}


def test_many_small_calls_equal_one_long_call_bit_for_bit() -> None:
    """Controller integrators, estimator, delay line, rangefinder hold and noise stream all
    travel in the state: 50 calls of 20 steps fly exactly like one call of 1000."""
    sticks = np.random.default_rng(3).uniform(-0.3, 0.3, (1000, 3))
    thrust = 0.55 + 0.02 * np.sin(np.arange(1000) / 50.0)
    one = Simulator(alt_hold=False, pilot=True, seed=5, settings=EFFECTS)
    s1, r1 = one.step(one.hover(0.5), 1000, sticks=sticks, thrust=thrust)
    many = Simulator(alt_hold=False, pilot=True, seed=5, settings=EFFECTS)
    state = many.hover(0.5)
    meas, truth = [], []
    for k in range(50):
        state, rec = many.step(state, 20, sticks=sticks[20 * k:20 * k + 20],
                               thrust=thrust[20 * k:20 * k + 20])
        meas.append(rec.meas)
        truth.append(rec.truth)
    assert np.array_equal(np.vstack(meas), r1.meas)
    assert np.array_equal(np.vstack(truth), r1.truth)
    assert np.array_equal(state.vector, s1.vector)
    assert state.t == pytest.approx(1.0)
    assert np.ptp(r1["true_p"]) > 0.1  # the sticks did something


def test_record_every_and_the_record_columns() -> None:
    sim = Simulator(noise=False)
    _, rec = sim.step(sim.hover(2.0), 100, record_every=20)
    assert rec.meas.shape[0] == 5 and np.allclose(rec.t, [0.0, 0.02, 0.04, 0.06, 0.08])
    assert rec["alt"][0] == pytest.approx(2.0) and rec["true_alt"][0] == pytest.approx(2.0)
    meas, truth = rec.frames()
    assert list(meas.columns[-6:]) == [f"m{i}" for i in range(1, 7)]
    assert "true_w6" in truth and meas.index.name == "t"
    with pytest.raises(KeyError):
        rec["nope"]


def test_thrust_goes_straight_to_the_mixer_without_altitude_hold() -> None:
    sim = Simulator(alt_hold=False, noise=False, ground_effect=False)
    state = sim.hover(3.0)
    state, rec = sim.step(state, 300, thrust=0.62)
    assert np.all(rec["u_thrust"] == 0.62)
    motors = np.column_stack([rec[f"m{i}"] for i in range(1, 7)])
    assert np.allclose(motors.mean(axis=1), 0.62, atol=1e-3)
    assert rec["true_vz"][-1] < -0.3  # more than hover thrust: climbing (NED z up is -)


def test_mass_change_mid_flight_is_caught_by_the_altitude_hold() -> None:
    quiet = {"battery_sag": False}
    sim = Simulator(noise=False, ground_effect=False, settings=quiet)
    state, _ = sim.step(sim.hover(3.0), 2000)
    sim.set_mass(5.0)
    state, rec = sim.step(state, 20000, record_every=10)
    assert rec["true_alt"].min() < 2.97  # the payload pulls it down first
    assert state.altitude == pytest.approx(3.0, abs=0.01)
    heavy = hover_trim(load_vehicle().with_settings({**quiet, "mass": 5.0}))
    assert rec["u_thrust"][-200:].mean() == pytest.approx(heavy.command, rel=2e-3)
    assert sim.mass == 5.0
    with pytest.raises(SimError, match="mass must be a positive number"):
        sim.set_mass(0.0)


def test_altitude_setpoint_profile_is_followed() -> None:
    sim = Simulator(noise=False)
    n = 10000
    t = np.arange(n) * sim.dt
    alt_sp = 1.0 + 0.3 * np.sin(2 * np.pi * t / 5.0)
    rate = 0.3 * 2 * np.pi / 5.0 * np.cos(2 * np.pi * t / 5.0)
    _, rec = sim.step(sim.hover(1.0), n, alt_sp=alt_sp, alt_rate=rate, record_every=10)
    err = rec["true_alt"][300:] - alt_sp[::10][300:]
    assert np.sqrt(np.mean(err**2)) < 0.05


def test_bad_calls_give_one_line_errors() -> None:
    with pytest.raises(SimError, match="loop_input must be one of"):
        Simulator(loop_input="thoughts")
    sim = Simulator(loop_input="motors")
    state = sim.hover(1.0)
    with pytest.raises(SimError, match="needs motors"):
        sim.step(state, 10)
    with pytest.raises(SimError, match=r"motors must be a scalar/row or have shape \(10, 6\)"):
        sim.step(state, 10, motors=np.zeros((10, 4)))
    with pytest.raises(SimError, match="n_steps and record_every must be"):
        sim.step(state, 0, motors=0.5)
    with pytest.raises(SimError, match="altitude must be a positive"):
        sim.hover(-1.0)
    with pytest.raises(SimError, match="unknown vehicle setting"):
        Simulator(settings={"thrust_scal": 1.0})


def test_mahony_kernel_equals_numpy_reference() -> None:
    rng = np.random.default_rng(0)
    n, dt = 3000, 1e-3
    gyro = 0.3 * rng.standard_normal((n, 3)) + [0.02, -0.01, 0.03]
    force = np.array([0.5, -0.3, -9.7]) + 0.3 * rng.standard_normal((n, 3))
    vel = np.cumsum(0.01 * rng.standard_normal((n, 3)), axis=0)
    yaw = 0.2 + 0.05 * rng.standard_normal(n)
    est0 = np.zeros(N_EST)
    est0[:4] = euler_to_quat(0.1, -0.05, 0.3)
    est0[EST_F + 3:EST_F + 6] = [0.0, 0.0, -9.8]
    q_ref, b_ref = mahony_reference(est0, gyro, force, vel, yaw, 0.4, 0.1, dt)
    est = est0.copy()
    work = np.zeros(7)
    for i in range(n):
        est[EST_F:EST_F + 3] = force[i]
        mahony_step(est, gyro[i], vel[i], yaw[i], 0.4, 0.1, dt, work)
        if i in (0, n // 2, n - 1):
            np.testing.assert_allclose(est[:4], q_ref[i], atol=1e-9)
            np.testing.assert_allclose(est[4:7], b_ref[i], atol=1e-9)
