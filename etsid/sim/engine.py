"""The whole flight in one compiled call: sensors → controller → RK4 step, recorded.

Each step of length ``dt`` (``P[DT]``): measure the state (noise drawn beforehand in
Python from the seeded generator, so runs are bit-reproducible), run the controller,
evaluate the first RK4 stage (whose auxiliary outputs — thrust, specific force, battery
voltage — are the values "at" this instant), record every ``k_out``-th step, finish the
RK4 step and renormalise the quaternion. Rotor inflow is warm-started from the previous
stage's solution.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from etsid.sim.body import quat_to_euler, wrap_pi
from etsid.sim.controller import MS_ALT, MS_ATT, MS_GYRO, MS_VEL, N_MS, control_step
from etsid.sim.dynamics import AUX_F, AUX_VBAT, N_AUX, N_WORK, derivative
from etsid.sim.params import (
    DT,
    NZ_ACC,
    NZ_ALT,
    NZ_ATT,
    NZ_GYRO,
    NZ_VBAT,
    NZ_VEL,
    RADIUS,
    X_OM,
    X_POS,
    X_Q,
    X_SOC,
    X_VEL,
    X_W,
)

# measured columns (before the motors m1..mN)
MEAS_COLUMNS = (
    "p", "q", "r", "roll", "pitch", "yaw", "u_roll", "u_pitch", "u_yaw", "u_thrust",
    "sp_p", "sp_q", "sp_r", "alt", "vx", "vy", "vz", "ax", "ay", "az", "vbat",
)
# true columns (before the per-rotor blocks w, T, Q, ge, vi)
TRUTH_COLUMNS = (
    "p", "q", "r", "roll", "pitch", "yaw", "x", "y", "z", "alt", "vx", "vy", "vz",
    "qw", "qx", "qy", "qz", "ax", "ay", "az", "vbat", "soc",
)
ROTOR_BLOCKS = ("w", "T", "Q", "ge", "vi")


@njit(cache=True)
def run_flight(
    x0: np.ndarray, P: np.ndarray, inertia: np.ndarray, rpos: np.ndarray,
    spin: np.ndarray, dists: np.ndarray, mix: np.ndarray, lam0: np.ndarray, cs0: np.ndarray,
    exc: np.ndarray, alt_sp: np.ndarray, alt_rate: np.ndarray, vel_sp: np.ndarray,
    thr_manual: np.ndarray, noise: np.ndarray, gyro_bias: np.ndarray, k_out: int,
    rf_every: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Fly ``exc.shape[0]`` steps and return the recorded measured and true signals.

    Parameters
    ----------
    x0 : ndarray
        Initial state (layout in :mod:`etsid.sim.params`).
    P : ndarray
        Parameter vector.
    inertia : ndarray
        Inertia tensor, kg m².
    rpos, spin, dists, mix : ndarray
        Rotor geometry and mixer (:func:`etsid.sim.params.geometry`).
    lam0 : ndarray
        Initial induced inflow ratios per rotor.
    cs0 : ndarray
        Initial controller state.
    exc : ndarray
        Stick excitation (n, 3) per step.
    alt_sp, alt_rate : ndarray
        Altitude setpoint (m) and its rate (m/s) per step.
    vel_sp : ndarray
        Pilot speed target (n, 2) forward/right, m/s.
    thr_manual : ndarray
        Manual collective per step (used when altitude hold is off).
    noise : ndarray
        (n, N_NOISE) measurement noise, already scaled to physical units.
    gyro_bias : ndarray
        Constant gyro bias, rad/s (3).
    k_out : int
        Record every ``k_out``-th step.
    rf_every : int
        Rangefinder sample period in steps (sample and hold).

    Returns
    -------
    meas : ndarray
        (n // k_out, len(MEAS_COLUMNS) + N) measured signals, motors last.
    truth : ndarray
        (n // k_out, len(TRUTH_COLUMNS) + 5 N) noise-free signals.
    """
    n_steps = exc.shape[0]
    n_rot = rpos.shape[0]
    n_out = n_steps // k_out
    nm = len(MEAS_COLUMNS)
    nt = len(TRUTH_COLUMNS)
    meas = np.empty((n_out, nm + n_rot))
    truth = np.empty((n_out, nt + 5 * n_rot))
    dt = P[DT]
    jinv = np.linalg.inv(inertia)
    x = x0.copy()
    nx = x.size
    lam = lam0.copy()
    cs = cs0.copy()
    ms = np.zeros(N_MS)
    m_cmd = np.zeros(n_rot)
    u = np.zeros(4)
    sp = np.zeros(3)
    thrust = np.zeros(n_rot)
    torque = np.zeros(n_rot)
    ge = np.zeros(n_rot)
    aux = np.zeros(N_AUX)
    aux_s = np.zeros(N_AUX)
    thr_s = np.zeros(n_rot)
    tq_s = np.zeros(n_rot)
    ge_s = np.zeros(n_rot)
    k1 = np.empty(nx)
    k2 = np.empty(nx)
    k3 = np.empty(nx)
    k4 = np.empty(nx)
    xs = np.empty(nx)
    work = np.zeros(N_WORK)
    alt_held = 0.0
    lam_rec = np.empty(n_rot)
    vel2 = np.empty(2)
    excv = np.empty(3)
    for i in range(n_steps):
        # --- sensors ------------------------------------------------------------------------
        roll, pitch, yaw = quat_to_euler(x[X_Q:X_Q + 4])
        for j in range(3):
            ms[MS_GYRO + j] = x[X_W + j] + gyro_bias[j] + noise[i, NZ_GYRO + j]
            ms[MS_VEL + j] = x[X_VEL + j] + noise[i, NZ_VEL + j]
        ms[MS_ATT] = roll + noise[i, NZ_ATT]
        ms[MS_ATT + 1] = pitch + noise[i, NZ_ATT + 1]
        ms[MS_ATT + 2] = wrap_pi(yaw + noise[i, NZ_ATT + 2])
        if i % rf_every == 0:
            alt_held = -x[X_POS + 2] + noise[i, NZ_ALT]
        ms[MS_ALT] = alt_held
        # --- controller ---------------------------------------------------------------------
        for j in range(3):
            excv[j] = exc[i, j]
        vel2[0] = vel_sp[i, 0]
        vel2[1] = vel_sp[i, 1]
        control_step(P, cs, ms, excv, alt_sp[i], alt_rate[i], vel2, thr_manual[i], mix, m_cmd,
                     u, sp)
        # --- RK4 ------------------------------------------------------------------------------
        derivative(x, m_cmd, P, inertia, jinv, rpos, spin, dists, lam, thrust, torque, ge, aux,
                   k1, work)
        if i % k_out == 0:
            o = i // k_out
            for j in range(n_rot):
                lam_rec[j] = lam[j]
            row = meas[o]
            for j in range(3):
                row[j] = ms[MS_GYRO + j]
                row[3 + j] = ms[MS_ATT + j]
                row[6 + j] = u[j]
                row[10 + j] = sp[j]
                row[14 + j] = ms[MS_VEL + j]
                row[17 + j] = aux[AUX_F + j] + noise[i, NZ_ACC + j]
            row[9] = u[3]
            row[13] = ms[MS_ALT]
            row[20] = aux[AUX_VBAT] + noise[i, NZ_VBAT]
            for j in range(n_rot):
                row[nm + j] = m_cmd[j]
            tr = truth[o]
            for j in range(3):
                tr[j] = x[X_W + j]
                tr[6 + j] = x[X_POS + j]
                tr[10 + j] = x[X_VEL + j]
                tr[17 + j] = aux[AUX_F + j]
            tr[3] = roll
            tr[4] = pitch
            tr[5] = yaw
            tr[9] = -x[X_POS + 2]
            qn = math.sqrt(np.sum(x[X_Q:X_Q + 4] ** 2))
            for j in range(4):
                tr[13 + j] = x[X_Q + j] / qn
            tr[20] = aux[AUX_VBAT]
            tr[21] = x[X_SOC]
            rad = P[RADIUS]
            for j in range(n_rot):
                om = x[X_OM + j]
                tr[nt + j] = om
                tr[nt + n_rot + j] = thrust[j]
                tr[nt + 2 * n_rot + j] = torque[j]
                tr[nt + 3 * n_rot + j] = ge[j]
                tr[nt + 4 * n_rot + j] = lam_rec[j] * max(om, 1.0) * rad
        for j in range(nx):
            xs[j] = x[j] + 0.5 * dt * k1[j]
        derivative(xs, m_cmd, P, inertia, jinv, rpos, spin, dists, lam, thr_s, tq_s, ge_s,
                   aux_s, k2, work)
        for j in range(nx):
            xs[j] = x[j] + 0.5 * dt * k2[j]
        derivative(xs, m_cmd, P, inertia, jinv, rpos, spin, dists, lam, thr_s, tq_s, ge_s,
                   aux_s, k3, work)
        for j in range(nx):
            xs[j] = x[j] + dt * k3[j]
        derivative(xs, m_cmd, P, inertia, jinv, rpos, spin, dists, lam, thr_s, tq_s, ge_s,
                   aux_s, k4, work)
        for j in range(nx):
            x[j] += dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        qn = math.sqrt(x[X_Q] ** 2 + x[X_Q + 1] ** 2 + x[X_Q + 2] ** 2 + x[X_Q + 3] ** 2)
        for j in range(4):
            x[X_Q + j] /= qn
    return meas, truth
