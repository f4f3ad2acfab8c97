"""Physics of the simulator against known answers: rotor, inflow, ground effect, rigid body."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from etsid.sim import hover_trim, load_vehicle
from etsid.sim.body import euler_to_quat, free_body, quat_to_dcm, quat_to_euler, wrap_pi
from etsid.sim.ground import CHEESEMAN_BENNETT, SANCHEZ_CUEVAS, cheeseman_bennett, ground_ratio
from etsid.sim.rotor import glauert_inflow_reference, rotor_forces, solve_inflow
from etsid.sim.trim import momentum_hover_velocity

VEH = load_vehicle("tarot680")
ROT = VEH["rotor"]
RHO = VEH["environment"]["air_density"]
AREA = VEH.rotor_area
ARGS = (RHO, ROT["radius"], VEH.solidity, ROT["lift_slope"], VEH.theta_0, ROT["twist"],
        ROT["cd0"], ROT["kappa"])
TRIM = hover_trim(VEH)


def forces(omega: float, v_climb: float = 0.0, v_inplane: float = 0.0) -> tuple[float, float]:
    """Thrust (N) and induced velocity (m/s) of one tarot680 rotor."""
    t, _, lam = rotor_forces(omega, v_climb, v_inplane, *ARGS, 0.05)
    return t, lam * omega * ROT["radius"]


@pytest.mark.parametrize("name", ["tarot680", "quad250"])
def test_hover_trim_thrust_equals_weight_and_momentum_inflow(name: str) -> None:
    veh = load_vehicle(name)
    trim = hover_trim(veh)
    g = veh["environment"]["gravity"]
    assert veh.n_rotors * trim.thrust == pytest.approx(veh.mass * g, rel=1e-9)
    v_h = momentum_hover_velocity(trim.thrust, veh["environment"]["air_density"],
                                  veh["rotor"]["radius"])
    assert trim.v_i == pytest.approx(v_h, rel=1e-9)
    assert 0.2 < trim.command < 0.8  # hover throttle of a sensible design


@pytest.mark.parametrize("v_climb", [0.5, 2.0, 5.0, 10.0])
def test_axial_climb_inflow_matches_momentum_theory(v_climb: float) -> None:
    t, v_i = forces(TRIM.omega, v_climb=v_climb)
    v_h2 = t / (2 * RHO * AREA)
    expected = -v_climb / 2 + math.sqrt((v_climb / 2) ** 2 + v_h2)
    assert v_i == pytest.approx(expected, rel=1e-8)


@pytest.mark.parametrize("speed", [2.0, 5.0, 10.0, 20.0])
def test_edgewise_flight_inflow_matches_glauert_closed_form(speed: float) -> None:
    t, v_i = forces(TRIM.omega, v_inplane=speed)
    v_h2 = t / (2 * RHO * AREA)
    # v_i^2 (V^2 + v_i^2) = v_h^4  ->  v_i^2 = (-V^2 + sqrt(V^4 + 4 v_h^4)) / 2
    expected = math.sqrt((-(speed**2) + math.sqrt(speed**4 + 4 * v_h2**2)) / 2)
    assert v_i == pytest.approx(expected, rel=1e-8)
    if speed >= 20.0:  # high advance ratio limit v_i -> T / (2 rho A V)
        assert v_i == pytest.approx(t / (2 * RHO * AREA * speed), rel=0.03)


def test_forward_flight_raises_thrust_at_fixed_speed() -> None:
    """Translational lift: same rotor speed, more thrust in edgewise flight."""
    t0, _ = forces(TRIM.omega)
    t1, _ = forces(TRIM.omega, v_inplane=8.0)
    assert t1 > 1.05 * t0


@settings(max_examples=60, deadline=None)
@given(
    omega=st.floats(300.0, 800.0),
    vc=st.floats(-2.0, 12.0),
    dv=st.floats(0.05, 3.0),
    vh=st.floats(0.0, 10.0),
)
def test_thrust_falls_with_climb_rate(omega: float, vc: float, dv: float, vh: float) -> None:
    t_slow, _ = forces(omega, vc, vh)
    t_fast, _ = forces(omega, vc + dv, vh)
    assert t_fast < t_slow or t_slow == 0.0  # a fixed-pitch rotor unloads completely


@settings(max_examples=60, deadline=None)
@given(mu=st.floats(0.0, 0.3), lam_c=st.floats(-0.02, 0.15), warm=st.floats(0.0, 0.2))
def test_inflow_newton_kernel_matches_reference(mu: float, lam_c: float, warm: float) -> None:
    s, a, th0, tw = VEH.solidity, ROT["lift_slope"], VEH.theta_0, ROT["twist"]
    ct, li, iters = solve_inflow(mu, lam_c, s, a, th0, tw, warm)
    ct_ref, li_ref = glauert_inflow_reference(mu, lam_c, s, a, th0, tw)
    assert iters <= 12
    assert li == pytest.approx(li_ref, rel=1e-7, abs=1e-10)
    assert ct == pytest.approx(ct_ref, rel=1e-7, abs=1e-12)


def test_torque_is_induced_plus_profile_power_in_hover() -> None:
    t, q, lam = rotor_forces(TRIM.omega, 0.0, 0.0, *ARGS, 0.05)
    v_i = lam * TRIM.omega * ROT["radius"]
    profile = VEH.solidity * ROT["cd0"] / 8 * RHO * AREA * (TRIM.omega * ROT["radius"]) ** 3
    assert q * TRIM.omega == pytest.approx(ROT["kappa"] * t * v_i + profile, rel=1e-9)
    figure_of_merit = t * v_i / (q * TRIM.omega)
    assert 0.5 < figure_of_merit < 0.8


@pytest.mark.parametrize("z_over_r", [0.6, 0.8, 1.0, 1.5, 2.0, 3.0, 4.9])
def test_ground_effect_ratio_matches_cheeseman_bennett(z_over_r: float) -> None:
    r = 0.165
    got = ground_ratio(z_over_r * r, r, CHEESEMAN_BENNETT, np.zeros(0), 0.3, 0.0, 0.5, 10.0)
    assert got == pytest.approx(1.0 / (1.0 - (1.0 / (4 * z_over_r)) ** 2), rel=1e-12)
    assert got == pytest.approx(cheeseman_bennett(np.array([z_over_r]))[0], rel=1e-12)


def test_ground_effect_clips_and_vanishes() -> None:
    r = 0.165
    none = np.zeros(0)
    at_clip = ground_ratio(0.5 * r, r, CHEESEMAN_BENNETT, none, 0.3, 0.0, 0.5, 10.0)
    assert ground_ratio(0.1 * r, r, CHEESEMAN_BENNETT, none, 0.3, 0.0, 0.5, 10.0) == at_clip
    assert ground_ratio(0.1 * r, r, CHEESEMAN_BENNETT, none, 0.3, 0.0, 0.5, 1.2) == 1.2
    far = ground_ratio(50.0 * r, r, CHEESEMAN_BENNETT, none, 0.3, 0.0, 0.5, 10.0)
    assert far == pytest.approx(1.0 / (1.0 - (1.0 / 200.0) ** 2), rel=1e-12)  # no cut-off
    heights = np.linspace(0.6 * r, 4.9 * r, 40)
    ratios = [ground_ratio(z, r, SANCHEZ_CUEVAS, np.array([0.34, 0.59, 0.68]), 0.34, 2.0, 0.5,
                           10.0) for z in heights]
    assert np.all(np.diff(ratios) < 0)  # falls monotonically with height


def test_multirotor_ground_effect_reduces_to_single_rotor_and_exceeds_it() -> None:
    r, z = 0.165, 0.3
    cb = ground_ratio(z, r, CHEESEMAN_BENNETT, np.zeros(0), 0.34, 0.0, 0.5, 10.0)
    alone = ground_ratio(z, r, SANCHEZ_CUEVAS, np.zeros(0), 1e6, 2.0, 0.5, 10.0)
    assert alone == pytest.approx(cb, rel=1e-9)
    # quadrotor: two neighbours at d, one at sqrt(2) d, body at b (paper's formula)
    d, b, kb = 0.3, 0.212, 2.0
    quad = ground_ratio(z, r, SANCHEZ_CUEVAS, np.array([d, d, math.sqrt(2) * d]), b, kb, 0.5,
                        10.0)
    paper = 1.0 / (1 - (r / (4 * z)) ** 2 - r**2 * z / (d**2 + 4 * z**2) ** 1.5
                   - r**2 / 2 * z / (2 * d**2 + 4 * z**2) ** 1.5
                   - 2 * r**2 * z * kb / (b**2 + 4 * z**2) ** 1.5)
    assert quad == pytest.approx(paper, rel=1e-12)
    assert quad > cb


def test_free_rigid_body_conserves_momentum_energy_and_unit_quaternion() -> None:
    inertia = VEH.inertia  # full tensor, products of inertia included
    assert np.count_nonzero(inertia - np.diag(np.diag(inertia))) == 6
    q0 = euler_to_quat(0.3, -0.2, 1.0)
    w0 = np.array([1.5, -0.7, 2.5])
    dt, n = 1e-3, 30_000  # 30 s of tumbling
    qs, ws = free_body(q0, w0, inertia, dt, n)
    R = np.empty((3, 3))
    moments = np.empty((n + 1, 3))
    for k in range(0, n + 1):
        quat_to_dcm(qs[k], R)
        moments[k] = R @ (inertia @ ws[k])
    energy = 0.5 * np.einsum("ij,jk,ik->i", ws, inertia, ws)
    assert np.max(np.abs(moments - moments[0])) < 1e-8 * np.linalg.norm(moments[0])
    assert np.max(np.abs(energy - energy[0])) < 1e-9 * energy[0]
    assert np.max(np.abs(np.linalg.norm(qs, axis=1) - 1.0)) < 1e-14
    assert np.ptp(ws[:, 0]) > 0.1  # the body really tumbles (not a principal-axis spin)


@settings(max_examples=50, deadline=None)
@given(st.floats(-3.0, 3.0), st.floats(-1.5, 1.5), st.floats(-3.1, 3.1))
def test_euler_quaternion_round_trip(roll: float, pitch: float, yaw: float) -> None:
    back = quat_to_euler(euler_to_quat(roll, pitch, yaw))
    assert back == pytest.approx((roll, pitch, yaw), abs=1e-9)


@given(st.floats(-50.0, 50.0))
def test_wrap_pi_range(a: float) -> None:
    w = wrap_pi(a)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-9)
