"""PID baseline sanity: holds a height with zero steady error, anti-windup, hover prior."""

from __future__ import annotations

import numpy as np
import pytest

from etsid.control.loop import fly
from etsid.control.pid import PID_GAINS, U_MAX, Feedback, Gains, PIDController
from etsid.control.plant import Observation
from etsid.control.scenarios import Scenario
from etsid.control.simplant import SimPlant
from etsid.sim import hover_trim, load_vehicle


def _obs(alt: float, vz: float = 0.0) -> Observation:
    return Observation(t=0.0, alt=alt, vz=vz, roll=0.0, pitch=0.0, true_alt=alt, mass=4.2)


def test_pid_hover_converges_to_the_blade_element_trim_in_ground_effect() -> None:
    hold = Scenario("hold", "constant 0.4 m", duration=20.0, start=0.4, centre=0.4)
    plant = SimPlant(seed=1)
    ctrl = PIDController(plant.dt, plant.hover_command)
    table = fly(hold, ctrl, plant).table
    err = table["alt_ref"] - table["true_alt"]
    # the free-air hover prior is too much thrust at 0.4 m: it climbs first ...
    assert err[table.index < 3.0].min() < -0.01
    # ... until the integrator has found the ground-effect trim
    assert abs(err[table.index > 15.0].mean()) < 0.002
    # in ground effect the hover collective is below the free-air prior; the loop's
    # command settles on the trim the blade-element model gives at the height flown
    veh = load_vehicle("tarot680")
    h = table["true_alt"][table.index > 15.0].mean()
    assert hover_trim(veh, h).command < plant.hover_command - 0.02
    u = table["u_thrust"][table.index > 15.0].mean()
    assert u == pytest.approx(hover_trim(veh, h).command, abs=0.003)
    assert ctrl.feedback.integral < 0.0


def test_conditional_integration_stops_winding_while_saturated() -> None:
    fb = Feedback(Gains(kp=1.0, kd=0.0, ki=1.0, i_limit=0.2), dt=0.1)
    fb.integrate(1.0, _obs(0.0), saturated=0)
    assert fb.integral == pytest.approx(0.1)
    for _ in range(10):  # saturated high with the error still asking for more: frozen
        fb.integrate(1.0, _obs(0.0), saturated=1)
    assert fb.integral == pytest.approx(0.1)
    fb.integrate(0.0, _obs(1.0), saturated=1)  # error reversed: may unwind
    assert fb.integral == pytest.approx(0.0)
    for _ in range(100):
        fb.integrate(1.0, _obs(0.0), saturated=0)
    assert fb.integral == pytest.approx(0.2)  # bounded contribution


def test_pid_recovers_from_a_saturating_climb_without_windup_overshoot() -> None:
    climb = Scenario("climb", "4 m step", duration=15.0, start=1.0, centre=1.0,
                     steps=((1.0, 5.0),))
    plant = SimPlant(seed=0)
    table = fly(climb, PIDController(plant.dt, plant.hover_command), plant).table
    assert (table["u_thrust"] >= U_MAX).sum() > 10  # it did saturate
    assert table["true_alt"].max() < 5.0 + 0.1 * 4.0
    assert abs(table["true_alt"].iloc[-1] - 5.0) < 0.02


def test_pid_feed_forward_is_the_hover_prior_and_gains_are_documented() -> None:
    plant = SimPlant()
    ctrl = PIDController(plant.dt, plant.hover_command)
    cmd = ctrl.update(0.0, _obs(2.0), Scenario("c", "", 1.0, 2.0, 2.0))
    assert cmd.u_ff == pytest.approx(0.5545, abs=1e-3)  # Tarot 680 free-air hover
    assert cmd.u == pytest.approx(cmd.u_ff)  # no error, no feedback
    assert (PID_GAINS.kp, PID_GAINS.kd, PID_GAINS.ki) == (1.35, 0.40, 0.48)
    assert np.isfinite(cmd.u_fb)
