"""One rotor: blade-element thrust coupled with Glauert's induced inflow, and rotor torque.

Non-dimensional quantities follow Leishman, *Principles of Helicopter Aerodynamics*
(2nd ed., ch. 2–3, 5): advance ratio μ = V_h/(ΩR), climb inflow λ_c = V_c/(ΩR),
induced inflow λ_i = v_i/(ΩR), total inflow λ = λ_c + λ_i (positive down through the disc).

* Blade element, linear twist θ(r) = θ_0 + θ_tw r, uniform inflow:
  C_T = (σa/2) [θ_0 (1/3 + μ²/2) + θ_tw/4 (1 + μ²) − λ/2]
* Glauert: λ_i = C_T / (2 sqrt(μ² + λ²))  ⇔  v_i = T / (2ρA sqrt(V_h² + (V_c + v_i)²))
* Power/torque: C_Q = C_P = κ λ_i C_T + λ_c C_T + (σ C_d0/8)(1 + 4.65 μ²)

The two equations are solved together by Newton's method on λ_i.
See docs/physics.md for the derivation and checks.
"""

from __future__ import annotations

import math

from numba import njit

NEWTON_ITERS = 12
NEWTON_TOL = 1e-12


@njit(cache=True)
def bemt_ct(mu: float, lam: float, sigma: float, a: float, th0: float, tw: float) -> float:
    """Blade-element thrust coefficient C_T for total inflow ratio ``lam`` (dimensionless).

    Parameters
    ----------
    mu : float
        Advance ratio V_h/(ΩR).
    lam : float
        Total inflow ratio λ = λ_c + λ_i, positive down through the disc.
    sigma, a, th0, tw : float
        Solidity, lift-curve slope (1/rad), root pitch θ_0 (rad), linear twist θ_tw (rad).
    """
    return 0.5 * sigma * a * (th0 * (1.0 / 3.0 + 0.5 * mu * mu) + 0.25 * tw * (1.0 + mu * mu)
                              - 0.5 * lam)


@njit(cache=True)
def solve_inflow(
    mu: float, lam_c: float, sigma: float, a: float, th0: float, tw: float, lam_i0: float
) -> tuple[float, float, int]:
    """Solve blade-element thrust and Glauert inflow together.

    Parameters
    ----------
    mu, lam_c : float
        Advance ratio and climb inflow ratio (positive in climb).
    sigma, a, th0, tw : float
        Rotor data, see :func:`bemt_ct`.
    lam_i0 : float
        Starting value of λ_i (the previous solution: warm start).

    Returns
    -------
    ct : float
        Thrust coefficient C_T = T / (ρ A (ΩR)²), clipped at 0.
    lam_i : float
        Induced inflow ratio v_i/(ΩR), ≥ 0.
    iters : int
        Newton iterations used.
    """
    k = 0.25 * sigma * a
    c0 = bemt_ct(mu, 0.0, sigma, a, th0, tw)
    if c0 - k * lam_c <= 0.0:  # no thrust even without induced flow (windmill side)
        return 0.0, 0.0, 0
    li_max = c0 / k - lam_c  # C_T > 0 requires lam_i < li_max; the root lies in (0, li_max)
    guess = min(math.sqrt(0.5 * (c0 - k * lam_c)), 0.9 * li_max)
    li = lam_i0
    if not 0.1 * guess < li < li_max:
        li = guess
    it = 0
    for it in range(1, NEWTON_ITERS + 1):  # noqa: B007
        lam = lam_c + li
        s = math.sqrt(mu * mu + lam * lam) + 1e-12
        ct = c0 - k * lam
        f = li - ct / (2.0 * s)
        df = 1.0 + k / (2.0 * s) + ct * lam / (2.0 * s * s * s)
        if df < 0.2:
            df = 0.2
        step = f / df
        li_new = li - step
        if li_new <= 0.0:
            li_new = 0.5 * li
        elif li_new >= li_max:
            li_new = 0.5 * (li + li_max)
        li = li_new
        if abs(step) < NEWTON_TOL:
            break
    return c0 - k * (lam_c + li), li, it


@njit(cache=True)
def power_coefficient(
    ct: float, lam_i: float, lam_c: float, mu: float, sigma: float, cd0: float, kappa: float
) -> float:
    """Power (= torque) coefficient C_P = C_Q, dimensionless: induced + climb + profile."""
    return kappa * lam_i * ct + lam_c * ct + sigma * cd0 / 8.0 * (1.0 + 4.65 * mu * mu)


@njit(cache=True)
def rotor_forces(
    omega: float, v_climb: float, v_inplane: float, rho: float, radius: float, sigma: float,
    a: float, th0: float, tw: float, cd0: float, kappa: float, lam_i0: float
) -> tuple[float, float, float]:
    """Thrust and shaft torque of one rotor out of ground effect.

    Parameters
    ----------
    omega : float
        Rotor speed Ω, rad/s (values below 1 rad/s are treated as 1 rad/s).
    v_climb : float
        Air velocity component along the rotor axis, V_c, m/s, positive in climb
        (air entering from above).
    v_inplane : float
        Magnitude of the in-plane air velocity V_h, m/s.
    rho, radius : float
        Air density (kg/m³) and rotor radius R (m).
    sigma, a, th0, tw, cd0, kappa : float
        Solidity, lift slope (1/rad), root pitch (rad), twist (rad), profile drag
        coefficient, induced power factor.
    lam_i0 : float
        Warm-start induced inflow ratio.

    Returns
    -------
    thrust : float
        T, N (along the rotor axis, ≥ 0).
    torque : float
        Aerodynamic shaft torque Q, N m.
    lam_i : float
        Solved induced inflow ratio (pass back as the next warm start).
    """
    om = omega if omega > 1.0 else 1.0
    tip = om * radius
    mu = v_inplane / tip
    lam_c = v_climb / tip
    ct, li, _ = solve_inflow(mu, lam_c, sigma, a, th0, tw, lam_i0)
    area = math.pi * radius * radius
    q_ref = rho * area * tip * tip
    cp = power_coefficient(ct, li, lam_c, mu, sigma, cd0, kappa)
    return ct * q_ref, cp * q_ref * radius, li


@njit(cache=True)
def ground_effect_torque(
    thrust_oge: float, lam_i: float, ratio: float, omega: float, v_climb: float,
    v_inplane: float, rho: float, radius: float, sigma: float, a: float, cd0: float,
    kappa: float,
) -> float:
    """Shaft torque of a rotor whose thrust ground effect raises by ``ratio`` at fixed Ω, N m.

    A fixed-pitch rotor gains thrust near the ground because its inflow falls: with
    C_T = c_0 − k λ (blade element, k = σa/4), a thrust ratio ρ at the same Ω means
    λ_i,IGE = λ_i − (ρ − 1) C_T / k, and the torque follows the reduced inflow,
    C_Q = κ λ_i,IGE ρ C_T + λ_c ρ C_T + (σ C_d0 / 8)(1 + 4.65 μ²).

    Parameters
    ----------
    thrust_oge, lam_i : float
        Out-of-ground-effect thrust (N) and induced inflow ratio at this Ω
        (:func:`rotor_forces`).
    ratio : float
        T_IGE / T_OGE.
    omega, v_climb, v_inplane, rho, radius, sigma, a, cd0, kappa : float
        As in :func:`rotor_forces`.
    """
    om = omega if omega > 1.0 else 1.0
    tip = om * radius
    mu = v_inplane / tip
    lam_c = v_climb / tip
    q_ref = rho * math.pi * radius * radius * tip * tip
    ct = thrust_oge / q_ref
    li = lam_i - (ratio - 1.0) * ct / (0.25 * sigma * a)
    li = li if li > 0.0 else 0.0
    return power_coefficient(ratio * ct, li, lam_c, mu, sigma, cd0, kappa) * q_ref * radius


def glauert_inflow_reference(
    mu: float, lam_c: float, sigma: float, a: float, th0: float, tw: float
) -> tuple[float, float]:
    """Plain scipy reference of :func:`solve_inflow` (bracketing root finder, for tests).

    Returns
    -------
    ct, lam_i : float
        Thrust coefficient and induced inflow ratio.
    """
    from scipy.optimize import brentq

    def residual(li: float) -> float:
        lam = lam_c + li
        ct = max(float(bemt_ct(mu, lam, sigma, a, th0, tw)), 0.0)
        return li - ct / (2.0 * math.sqrt(mu * mu + lam * lam) + 1e-300)

    k = 0.25 * sigma * a
    c0 = float(bemt_ct(mu, 0.0, sigma, a, th0, tw))
    if c0 - k * lam_c <= 0.0:
        return 0.0, 0.0
    li = brentq(residual, 0.0, c0 / k - lam_c, xtol=1e-15, rtol=1e-14)
    return max(float(bemt_ct(mu, lam_c + li, sigma, a, th0, tw)), 0.0), li


def hover_omega(thrust: float, rho: float, radius: float, sigma: float, a: float,
                th0: float, tw: float) -> float:
    """Rotor speed (rad/s) at which one rotor in hover (μ = λ_c = 0) gives ``thrust`` N."""
    from scipy.optimize import brentq

    def residual(om: float) -> float:
        t, _, _ = rotor_forces(om, 0.0, 0.0, rho, radius, sigma, a, th0, tw, 0.0, 1.0, 0.05)
        return t - thrust

    return float(brentq(residual, 1.0, 1e5, xtol=1e-12))


__all__ = [
    "bemt_ct",
    "glauert_inflow_reference",
    "ground_effect_torque",
    "hover_omega",
    "power_coefficient",
    "rotor_forces",
    "solve_inflow",
]
