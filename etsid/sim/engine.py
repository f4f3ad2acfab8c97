"""The flight loop in one compiled call: sensors → estimator → controller → delay → RK4.

:func:`advance` moves a *full state* vector S (rigid body, rotors, inflow warm start,
controller, estimator, rangefinder hold, step counter, motor-command delay line; offsets
from :func:`state_offsets`) by any number of physics steps; :func:`run_flight` is a whole
flight from one state. Each step of length ``dt`` (``P[DT]``): measure the state (noise
drawn beforehand in Python from the seeded generator, so runs are bit-reproducible), run
the estimator (if on) and the controller, pass the motor commands through the transport
delay, evaluate the first RK4 stage (whose auxiliary outputs — thrust, specific force,
battery voltage — are the values "at" this instant), record every ``k_out``-th step, finish
the RK4 step and renormalise the quaternion. Rotor inflow is warm-started from the
previous stage's solution.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from etsid.sim.body import quat_to_euler, wrap_pi
from etsid.sim.controller import MS_ALT, MS_ATT, MS_GYRO, MS_VEL, N_CS, N_MS, control_step
from etsid.sim.dynamics import AUX_F, AUX_VBAT, N_AUX, N_WORK, derivative
from etsid.sim.estimator import EST_B, EST_F, EST_Q, N_EST, mahony_step
from etsid.sim.params import (
    ACCEL_BIAS,
    DELAY,
    DT,
    EST_KI,
    EST_KP,
    EST_ON,
    GYRO_BIAS,
    LOG_MEAN,
    LOOP_INPUT,
    LOOP_MOTORS,
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


# --- full state vector S: x | inflow | controller | estimator | misc | delay line ---------
MISC_ALT = 0    # rangefinder altitude held between samples, m
MISC_STEP = 1   # physics steps flown since the start (sets the rangefinder phase)
MISC_HEAD = 2   # next write slot of the delay line
N_MISC = 3


@njit(cache=True)
def state_offsets(n_rot: int) -> tuple[int, int, int, int, int]:
    """Offsets of the inflow, controller, estimator, misc and delay-line blocks in S."""
    o_lam = X_OM + n_rot
    o_cs = o_lam + n_rot
    o_est = o_cs + N_CS
    o_misc = o_est + N_EST
    return o_lam, o_cs, o_est, o_misc, o_misc + N_MISC


@njit(cache=True)
def advance(
    S: np.ndarray, P: np.ndarray, inertia: np.ndarray, rpos: np.ndarray, spin: np.ndarray,
    dists: np.ndarray, mix: np.ndarray, exc: np.ndarray, alt_sp: np.ndarray,
    alt_rate: np.ndarray, vel_sp: np.ndarray, thr_manual: np.ndarray, motors: np.ndarray,
    noise: np.ndarray, k_out: int, rf_every: int, meas: np.ndarray, truth: np.ndarray,
) -> None:
    """Fly ``exc.shape[0]`` physics steps from the full state ``S`` (updated in place).

    Parameters
    ----------
    S : ndarray
        Full state (layout: :func:`state_offsets`).
    P : ndarray
        Parameter vector (:mod:`etsid.sim.params`).
    inertia : ndarray
        Inertia tensor about the CG, kg m².
    rpos, spin, dists, mix : ndarray
        Rotor geometry and mixer (:func:`etsid.sim.params.geometry`).
    exc : ndarray
        (n, 3) loop commands per step, read as ``P[LOOP_INPUT]`` says (sticks by default).
    alt_sp, alt_rate : ndarray
        (n,) altitude setpoint (m) and its rate (m/s), used by the altitude hold.
    vel_sp : ndarray
        (n, 2) pilot speed target forward/right, m/s.
    thr_manual : ndarray
        (n,) collective 0..1 used when the altitude hold is off.
    motors : ndarray
        (n, N) motor outputs 0..1 when ``P[LOOP_INPUT] == LOOP_MOTORS`` (else unused).
    noise : ndarray
        (n, N_NOISE) measurement noise in physical units.
    k_out : int
        Record every ``k_out``-th step (row ``i // k_out``). With ``P[LOG_MEAN]`` set, a
        row's motor outputs are the mean of the commands of its ``k_out`` steps (those the
        motors received over the row's period) instead of the first step's.
    rf_every : int
        Rangefinder sample period in steps (sample and hold).
    meas, truth : ndarray
        Out: ((n + k_out − 1) // k_out, …) measured and true rows (see MEAS_COLUMNS,
        TRUTH_COLUMNS).
    """
    n_steps = exc.shape[0]
    n_rot = rpos.shape[0]
    o_lam, o_cs, o_est, o_misc, o_buf = state_offsets(n_rot)
    cap = (S.size - o_buf) // n_rot
    nm = len(MEAS_COLUMNS)
    nt = len(TRUTH_COLUMNS)
    dt = P[DT]
    jinv = np.linalg.inv(inertia)
    nx = o_lam
    # work on private copies (no aliasing between the blocks: faster), written back at the end
    x = S[:nx].copy()
    lam = S[o_lam:o_cs].copy()
    cs = S[o_cs:o_est].copy()
    est = S[o_est:o_misc].copy()
    buf = S[o_buf:o_buf + cap * n_rot].copy().reshape((cap, n_rot))
    est_on = P[EST_ON] > 0.5
    mode = int(P[LOOP_INPUT])
    log_mean = P[LOG_MEAN] > 0.5
    delay = P[DELAY]
    n_del = int(delay)
    f_del = delay - n_del
    ms = np.zeros(N_MS)
    gyro = np.zeros(3)
    m_cmd = np.zeros(n_rot)
    m_app = np.zeros(n_rot)
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
    ework = np.zeros(7)
    alt_held = S[o_misc + MISC_ALT]
    step = int(S[o_misc + MISC_STEP])
    head = int(S[o_misc + MISC_HEAD])
    lam_rec = np.empty(n_rot)
    vel2 = np.empty(2)
    excv = np.empty(3)
    for i in range(n_steps):
        # --- sensors ------------------------------------------------------------------------
        roll, pitch, yaw = quat_to_euler(x[X_Q:X_Q + 4])
        for j in range(3):
            gyro[j] = x[X_W + j] + P[GYRO_BIAS + j] + noise[i, NZ_GYRO + j]
            ms[MS_GYRO + j] = gyro[j]
            ms[MS_VEL + j] = x[X_VEL + j] + noise[i, NZ_VEL + j]
        if est_on:
            mahony_step(est, gyro, ms[MS_VEL:MS_VEL + 3], wrap_pi(yaw + noise[i, NZ_ATT + 2]),
                        P[EST_KP], P[EST_KI], dt, ework)
            e_roll, e_pitch, e_yaw = quat_to_euler(est[EST_Q:EST_Q + 4])
            ms[MS_ATT] = e_roll
            ms[MS_ATT + 1] = e_pitch
            ms[MS_ATT + 2] = e_yaw
            for j in range(3):
                ms[MS_GYRO + j] = gyro[j] - est[EST_B + j]
        else:
            ms[MS_ATT] = roll + noise[i, NZ_ATT]
            ms[MS_ATT + 1] = pitch + noise[i, NZ_ATT + 1]
            ms[MS_ATT + 2] = wrap_pi(yaw + noise[i, NZ_ATT + 2])
        if step % rf_every == 0:
            alt_held = -x[X_POS + 2] + noise[i, NZ_ALT]
        ms[MS_ALT] = alt_held
        # --- controller ---------------------------------------------------------------------
        if mode == LOOP_MOTORS:
            for j in range(n_rot):
                m = motors[i, j]
                m_cmd[j] = 0.0 if m < 0.0 else (1.0 if m > 1.0 else m)
            for j in range(3):
                u[j] = 0.0
                sp[j] = 0.0
            u[3] = 0.0
            for j in range(n_rot):
                u[3] += m_cmd[j] / n_rot
        else:
            for j in range(3):
                excv[j] = exc[i, j]
            vel2[0] = vel_sp[i, 0]
            vel2[1] = vel_sp[i, 1]
            control_step(P, cs, ms, excv, alt_sp[i], alt_rate[i], vel2, thr_manual[i], mix,
                         m_cmd, u, sp)
        # --- transport delay: the motors see the command of `delay` steps ago ---------------
        if delay > 0.0:
            for j in range(n_rot):
                buf[head, j] = m_cmd[j]
            i0 = (head - n_del) % cap
            i1 = (head - n_del - 1) % cap
            for j in range(n_rot):
                m_app[j] = buf[i0, j]
                if f_del > 0.0:
                    m_app[j] = (1.0 - f_del) * buf[i0, j] + f_del * buf[i1, j]
            head = (head + 1) % cap
        else:
            for j in range(n_rot):
                m_app[j] = m_cmd[j]
        # --- RK4 ------------------------------------------------------------------------------
        derivative(x, m_app, P, inertia, jinv, rpos, spin, dists, lam, thrust, torque, ge, aux,
                   k1, work)
        for j in range(3):  # accelerometer sample, used by the estimator on the next step
            est[EST_F + j] = aux[AUX_F + j] + noise[i, NZ_ACC + j] + P[ACCEL_BIAS + j]
        if log_mean and i % k_out != 0:
            # running mean of the commands over the log period of row i // k_out
            w_new = 1.0 / (i % k_out + 1)
            row = meas[i // k_out]
            for j in range(n_rot):
                row[nm + j] += w_new * (m_cmd[j] - row[nm + j])
        if i % k_out == 0:
            o = i // k_out
            for j in range(n_rot):
                lam_rec[j] = lam[j]
            row = meas[o]
            for j in range(3):
                row[j] = gyro[j]
                row[3 + j] = ms[MS_ATT + j]
                row[6 + j] = u[j]
                row[10 + j] = sp[j]
                row[14 + j] = ms[MS_VEL + j]
                row[17 + j] = est[EST_F + j]
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
        derivative(xs, m_app, P, inertia, jinv, rpos, spin, dists, lam, thr_s, tq_s, ge_s,
                   aux_s, k2, work)
        for j in range(nx):
            xs[j] = x[j] + 0.5 * dt * k2[j]
        derivative(xs, m_app, P, inertia, jinv, rpos, spin, dists, lam, thr_s, tq_s, ge_s,
                   aux_s, k3, work)
        for j in range(nx):
            xs[j] = x[j] + dt * k3[j]
        derivative(xs, m_app, P, inertia, jinv, rpos, spin, dists, lam, thr_s, tq_s, ge_s,
                   aux_s, k4, work)
        for j in range(nx):
            x[j] += dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        qn = math.sqrt(x[X_Q] ** 2 + x[X_Q + 1] ** 2 + x[X_Q + 2] ** 2 + x[X_Q + 3] ** 2)
        for j in range(4):
            x[X_Q + j] /= qn
        step += 1
    S[:nx] = x
    S[o_lam:o_cs] = lam
    S[o_cs:o_est] = cs
    S[o_est:o_misc] = est
    S[o_buf:o_buf + cap * n_rot] = buf.ravel()
    S[o_misc + MISC_ALT] = alt_held
    S[o_misc + MISC_STEP] = step
    S[o_misc + MISC_HEAD] = head


@njit(cache=True)
def run_flight(
    S: np.ndarray, P: np.ndarray, inertia: np.ndarray, rpos: np.ndarray, spin: np.ndarray,
    dists: np.ndarray, mix: np.ndarray, exc: np.ndarray, alt_sp: np.ndarray,
    alt_rate: np.ndarray, vel_sp: np.ndarray, thr_manual: np.ndarray, motors: np.ndarray,
    noise: np.ndarray, k_out: int, rf_every: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Fly ``exc.shape[0]`` steps from a copy of ``S``; return measured and true records.

    Arguments as in :func:`advance`. Returns ``meas`` ((n+k_out−1)//k_out,
    len(MEAS_COLUMNS) + N, motors last) and ``truth`` (…, len(TRUTH_COLUMNS) + 5 N).
    """
    n_rot = rpos.shape[0]
    n_out = (exc.shape[0] + k_out - 1) // k_out
    meas = np.empty((n_out, len(MEAS_COLUMNS) + n_rot))
    truth = np.empty((n_out, len(TRUTH_COLUMNS) + 5 * n_rot))
    advance(S.copy(), P, inertia, rpos, spin, dists, mix, exc, alt_sp, alt_rate, vel_sp,
            thr_manual, motors, noise, k_out, rf_every, meas, truth)
    return meas, truth
