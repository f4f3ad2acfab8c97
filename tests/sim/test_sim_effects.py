"""Every optional effect leaves its physical signature (issue 12's proof list).

Noise-free vehicles (sensor noise off) with battery sag and ground effect off where they
would blur a signature; each test can fail if the effect is modelled wrongly.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from etsid.sim import hover_trim, load_vehicle, simulate
from etsid.sim.dynamics import N_AUX, N_WORK, derivative
from etsid.sim.params import J_ROT, X_OM, X_W
from etsid.sim.plant import initial_state, make_plant
from etsid.sim.rotor import bemt_ct, ground_effect_torque, power_coefficient, rotor_forces
from etsid.sim.stepper import Simulator

QUIET = {"sensors.gyro_std": 0.0, "sensors.gyro_bias_std": 0.0, "sensors.accel_std": 0.0,
         "sensors.att_std": 0.0, "sensors.vel_std": 0.0, "sensors.alt_std": 0.0,
         "sensors.vbat_std": 0.0, "battery_sag": False}


def quiet(**effects: object) -> dict[str, object]:
    return {f"vehicle.{k}": v for k, v in {**QUIET, **effects}.items()}


def motor_run(settings: dict[str, object], commands: np.ndarray) -> np.ndarray:
    """True rotor-1 speed per 1 ms step for open-loop motor commands (n,) on all rotors."""
    sim = Simulator(loop_input="motors", noise=False, ground_effect=False,
                    settings={**QUIET, **settings})
    state = sim.hover(3.0)
    motors = np.repeat(commands[:, None], sim.vehicle.n_rotors, axis=1)
    _, rec = sim.step(state, len(commands), motors=motors)
    return rec["true_w1"]


def test_time_delay_shifts_the_motor_step_response_by_exactly_the_delay() -> None:
    hover = hover_trim(load_vehicle().with_settings({"battery_sag": False})).command
    cmd = np.full(400, hover)
    cmd[100:] = hover + 0.1
    plain = motor_run({}, cmd)
    delayed = motor_run({"time_delay": 0.023}, cmd)
    assert np.ptp(plain) > 50.0  # the step is there
    np.testing.assert_allclose(delayed[123:], plain[100:-23], rtol=1e-12)
    np.testing.assert_allclose(delayed[:124], plain[0], rtol=1e-12)  # nothing before 123 ms
    half = motor_run({"time_delay": 0.0235}, cmd)  # fractional delays interpolate
    assert np.all(half[130:300] <= delayed[130:300] + 1e-9)
    assert np.all(half[130:300] >= plain[106:276] - 1e-9)


def _time_constant(w: np.ndarray, dt: float = 1e-3) -> float:
    """First-order time constant from the log of the distance to the final value."""
    dist = np.abs(w - w[-1])
    k = np.arange(w.size)
    use = (dist > 0.05 * dist[0]) & (dist < 0.9 * dist[0])
    slope = np.polyfit(k[use] * dt, np.log(dist[use]), 1)[0]
    return -1.0 / slope


def test_asymmetric_motor_lag_spins_down_slower_by_the_set_ratio() -> None:
    hover = hover_trim(load_vehicle().with_settings({"battery_sag": False})).command
    cmd = np.concatenate([np.full(800, hover + 0.2), np.full(800, hover - 0.2)])
    w = motor_run({"motor_lag": [0.03, 0.09]}, cmd)
    tau_up = _time_constant(w[:800])
    tau_down = _time_constant(w[800:])
    assert tau_up == pytest.approx(0.03, rel=0.02)
    assert tau_down == pytest.approx(0.09, rel=0.02)
    assert tau_down / tau_up == pytest.approx(3.0, rel=0.03)
    sym = motor_run({}, cmd)  # the file's symmetric 0.05 s both ways
    assert _time_constant(sym[:800]) == pytest.approx(_time_constant(sym[800:]), rel=0.02)


def _hover(settings: dict[str, object], duration: float = 12.0):
    return simulate("hover-oge", duration=duration, ground_effect=False, excitation="none",
                    settings=settings)


def test_thrust_scale_changes_the_hover_speed_and_command_by_inverse_sqrt() -> None:
    s = 1.21
    veh = load_vehicle().with_settings({"battery_sag": False})
    nominal = hover_trim(veh)  # the vehicle without the effect
    flight = _hover(quiet(thrust_scale=s))
    late = flight.table.index > 6.0
    omega = flight.truth.loc[late, [f"true_w{i}" for i in range(1, 7)]].to_numpy().mean()
    assert omega == pytest.approx(nominal.omega / math.sqrt(s), rel=1e-4)
    m = veh["motor"]
    top = m["omega_max"] * nominal.vbat / m["v_ref"]
    expected = (nominal.omega / math.sqrt(s) - m["omega_idle"]) / (top - m["omega_idle"])
    assert flight.table.loc[late, "u_thrust"].mean() == pytest.approx(expected, rel=1e-4)
    assert expected < nominal.command - 0.03


def _accelerations(settings: dict[str, object]) -> np.ndarray:
    """Body angular acceleration of a hovering state with the CCW rotors 5 % faster."""
    veh = load_vehicle().with_settings({**{k.split(".", 1)[-1] if k.startswith("vehicle.")
                                           else k: v for k, v in settings.items()},
                                        "battery_sag": False})
    plant = make_plant(veh, dt=1e-3, ground_effect=False)
    P = plant.P.copy()
    P[J_ROT] = 0.0  # aerodynamic moments only
    n = veh.n_rotors
    x = initial_state(plant, 3.0, ground_effect=False)[:X_OM + n].copy()
    x[X_OM:] *= np.where(veh.spin > 0, 1.05, 1.0)
    x[X_OM + 1] *= 1.02  # and one rotor faster: some roll/pitch moment too
    out = np.zeros_like(x)
    derivative(x, np.full(n, 0.5), P, plant.inertia, np.linalg.inv(plant.inertia), plant.rpos,
               plant.spin, plant.dists, np.full(n, 0.06), np.zeros(n), np.zeros(n),
               np.zeros(n), np.zeros(N_AUX), out, np.zeros(N_WORK))
    return np.linalg.solve(np.linalg.inv(plant.inertia), out[X_W:X_W + 3])  # J ω̇ (ω = 0)


def test_torque_scale_changes_yaw_authority_only() -> None:
    base = _accelerations({})
    scaled = _accelerations({"torque_scale": 1.5})
    assert abs(base[2]) > 0.02  # N m
    assert scaled[2] == pytest.approx(1.5 * base[2], rel=1e-9)
    np.testing.assert_allclose(scaled[:2], base[:2], rtol=1e-9, atol=1e-12)
    # in closed loop: the same roll-step response; the same yaw-rate step flown with a
    # smaller motor differential (the rate loop needs less yaw demand)
    a = simulate("steps", settings=quiet())
    b = simulate("steps", settings=quiet(torque_scale=2.0))
    roll_step = (a.table.index > 2.0) & (a.table.index < 4.0)
    err = np.abs(a.truth["true_roll"] - b.truth["true_roll"])[roll_step].max()
    assert err < 0.02 * a.truth["true_roll"][roll_step].abs().max()
    yaw_step = (a.table.index > 10.0) & (a.table.index < 12.0)
    spin = a.vehicle.spin

    def differential(flight) -> float:
        m = flight.table[[f"m{i + 1}" for i in range(6)]].to_numpy()[yaw_step]
        return float(np.mean(m[:, spin > 0].mean(axis=1) - m[:, spin < 0].mean(axis=1)))

    assert b.truth["true_r"][yaw_step].mean() == pytest.approx(
        a.truth["true_r"][yaw_step].mean(), rel=0.1)
    assert differential(b) < 0.7 * differential(a)


def test_inertia_scale_divides_angular_acceleration() -> None:
    veh = load_vehicle()
    base = make_plant(veh, dt=1e-3).inertia
    scaled = make_plant(veh.with_settings({"inertia_scale": 1.3}), dt=1e-3).inertia
    np.testing.assert_allclose(scaled, 1.3 * base, rtol=1e-12)
    axes = make_plant(veh.with_settings({"inertia_scale": [1.0, 4.0, 1.0]}), dt=1e-3).inertia
    assert axes[1, 1] == pytest.approx(4.0 * base[1, 1]) and axes[0, 0] == base[0, 0]
    assert axes[0, 1] == pytest.approx(2.0 * base[0, 1])
    assert np.all(np.linalg.eigvalsh(axes) > 0)


def _roll_rate_after_differential(settings: dict[str, object]) -> float:
    """True roll rate (rad/s) 50 ms after the right-hand rotors are commanded 4 % down from
    hover, open loop, in flight (the signature of inertia in a flown vehicle)."""
    sim = Simulator(loop_input="motors", noise=False, ground_effect=False,
                    settings={**QUIET, **settings})
    state = sim.hover(3.0)
    n = sim.vehicle.n_rotors
    right = sim.vehicle.rotor_positions[:, 1] > 1e-6
    motors = np.full((50, n), sim.hover_command)
    motors[:, right] -= 0.04
    _, rec = sim.step(state, 50, motors=motors)
    return float(rec["true_p"][-1])


def test_inertia_scale_slows_the_flown_roll_response_by_the_scale() -> None:
    base = _roll_rate_after_differential({})
    doubled = _roll_rate_after_differential({"inertia_scale": 2.0})
    roll_only = _roll_rate_after_differential({"inertia_scale": [2.0, 1.0, 1.0]})
    pitch_only = _roll_rate_after_differential({"inertia_scale": [1.0, 2.0, 1.0]})
    assert base > 0.05  # right side weaker: right side drops, a positive roll in FRD
    assert doubled == pytest.approx(base / 2.0, rel=0.03)  # same torque, twice the inertia
    assert roll_only == pytest.approx(base / 2.0, rel=0.03)
    assert pitch_only == pytest.approx(base, rel=0.03)  # only the axis that was scaled


@pytest.mark.parametrize(("cg", "moment"), [([0.03, -0.02, 0.0], [0.0, 0.0, 0.0]),
                                            ([0.0, 0.0, 0.0], [0.4, -0.3, 0.0])])
def test_cg_or_torque_offset_needs_steady_differential_thrust_to_hover_level(
        cg: list[float], moment: list[float]) -> None:
    flight = _hover(quiet(cg_offset=cg, torque_offset=moment), duration=20.0)
    late = flight.table.index > 12.0
    truth = flight.truth[late]
    assert truth[["true_roll", "true_pitch"]].abs().max().max() < math.radians(0.3)
    veh = flight.vehicle
    thrust = truth[[f"true_T{i}" for i in range(1, 7)]].to_numpy().mean(axis=0)
    pos = veh.rotor_positions
    weight = veh.mass * veh["environment"]["gravity"]
    # moment balance about the CG: thrust centroid under the CG, shifted by the moment
    cx = thrust @ pos[:, 0] / thrust.sum()
    cy = thrust @ pos[:, 1] / thrust.sum()
    assert cx == pytest.approx(cg[0] - moment[1] / weight, abs=1e-3)
    assert cy == pytest.approx(cg[1] + moment[0] / weight, abs=1e-3)
    assert np.ptp(thrust) > 0.3  # a steady differential, several newtons of difference
    plain = _hover(quiet(), duration=20.0).truth[late]
    assert np.ptp(plain[[f"true_T{i}" for i in range(1, 7)]].to_numpy().mean(axis=0)) < 0.02


def test_gyro_bias_shows_in_the_gyro_and_offsets_the_estimated_attitude() -> None:
    bias = [0.01, -0.01, 0.005]
    kp = 0.5
    flight = _hover(quiet(gyro_bias=bias, estimator="mahony", estimator_kp=kp,
                          estimator_ki=0.0), duration=50.0)
    table, truth = flight.table, flight.truth
    late = table.index > 35.0  # estimator settled (1/kp = 2 s) and the pilot's slow drift
    for i, axis in enumerate("pqr"):
        err = (table[axis] - truth[f"true_{axis}"])[late]
        assert err.mean() == pytest.approx(bias[i], abs=1e-9)
    for i, axis in enumerate(["roll", "pitch", "yaw"]):
        err = (table[axis] - truth[f"true_{axis}"])[late].mean()
        assert err == pytest.approx(math.asin(bias[i] / kp), rel=0.04), axis
    # the vehicle hovers level over its spot, and what the log shows is the pilot holding
    # a stick offset: against the estimator's tilt δ, and against the biased gyro, which the
    # rate loop drives to a setpoint b = angle_kp (φ_sp − φ̂) while the body does not turn
    delta = math.asin(bias[0] / kp)
    assert abs(truth.loc[late, "true_roll"].mean()) < 0.1 * delta
    ctrl = flight.vehicle["controller"]
    stick = (delta + bias[0] / ctrl["angle_kp"]) / math.radians(ctrl["max_tilt_deg"])
    assert table.loc[late, "u_roll"].mean() == pytest.approx(stick, rel=0.03)
    # with bias learning on, the estimator finds the bias and the attitude error vanishes
    learn = _hover(quiet(gyro_bias=bias, estimator="mahony", estimator_kp=kp,
                         estimator_ki=0.1), duration=40.0)
    late = learn.table.index > 30.0
    roll_err = (learn.table["roll"] - learn.truth["true_roll"])[late].abs().mean()
    assert roll_err < 0.1 * math.asin(bias[0] / kp)


def test_accel_bias_tilts_the_estimate_by_its_angle() -> None:
    flight = _hover(quiet(accel_bias=[0.0, 0.3, 0.0], estimator="mahony", estimator_kp=0.5,
                          estimator_ki=0.0), duration=50.0)
    late = flight.table.index > 35.0
    err = (flight.table["roll"] - flight.truth["true_roll"])[late].mean()
    # measured down direction -(f + b)/|f + b| with f = (0, 0, -g) leans to -y: the
    # estimate rolls left of the truth by atan(b/g)
    g = flight.vehicle["environment"]["gravity"]
    assert err == pytest.approx(-math.atan(0.3 / g), rel=0.04)
    assert (flight.table["ay"] - flight.truth["true_ay"]).mean() == pytest.approx(0.3)


def test_ground_effect_torque_follows_the_reduced_inflow() -> None:
    veh = load_vehicle()
    r = veh["rotor"]
    args = (1.225, r["radius"], veh.solidity, r["lift_slope"], veh.theta_0, r["twist"])
    for omega, v_climb, v_h, ratio in [(537.0, 0.0, 0.0, 1.18), (600.0, 0.5, 2.0, 1.05)]:
        t, q, li = rotor_forces(omega, v_climb, v_h, *args, r["cd0"], r["kappa"], 0.05)
        q_ige = ground_effect_torque(t, li, ratio, omega, v_climb, v_h, 1.225, r["radius"],
                                     veh.solidity, r["lift_slope"], r["cd0"], r["kappa"])
        # independent: the inflow at which blade-element thrust is ratio times larger
        tip = omega * r["radius"]
        mu, lam_c = v_h / tip, v_climb / tip
        q_ref = 1.225 * math.pi * r["radius"] ** 2 * tip**2
        ct = ratio * t / q_ref
        lam = brentq(lambda lam, mu=mu, ct=ct: bemt_ct(mu, lam, *args[2:]) - ct, -1.0, 1.0,
                     xtol=1e-15)
        cq = power_coefficient(ct, lam - lam_c, lam_c, mu, veh.solidity, r["cd0"], r["kappa"])
        assert q_ige == pytest.approx(cq * q_ref * r["radius"], rel=1e-9)
        assert q_ige < q  # more thrust from less inflow: less induced torque
    # in flight: the IGE hover needs less power (Georgiev et al. 2022; Leishman ch. 13)
    kw = {"duration": 4.0, "excitation": "none", "alt_wander": 0.0}
    on = simulate("hover-ige", settings=quiet(ground_effect_torque=True), **kw).truth
    off = simulate("hover-ige", settings=quiet(), **kw).truth
    q_on = on[[f"true_Q{i}" for i in range(1, 7)]].to_numpy().mean()
    q_off = off[[f"true_Q{i}" for i in range(1, 7)]].to_numpy().mean()
    assert 0.85 < q_on / q_off < 0.98


def test_a_weak_motor_is_trimmed_by_the_others() -> None:
    """One rotor at 0.8× thrust (a chipped propeller): the rate loop holds the hover by
    commanding that motor higher and its opposite lower; the others stay near the mean."""
    kw = dict(scenario="hover-oge", duration=15.0, seed=2)
    plain = simulate(**kw).table
    weak = simulate(**kw, settings={"vehicle.weak_motor": [3, 0.8]}).table
    m_plain = plain[[f"m{i}" for i in range(1, 7)]].mean().to_numpy()
    m_weak = weak[[f"m{i}" for i in range(1, 7)]].mean().to_numpy()
    assert np.ptp(m_plain) < 0.005
    assert m_weak[2] - m_plain[2] > 0.03
    assert int(np.argmax(m_weak)) == 2
