"""Attitude estimator of the kind autopilots run: Mahony's explicit complementary filter.

Mahony, Hamel & Pflimlin, *Nonlinear complementary filters on the special orthogonal
group*, IEEE Trans. Automatic Control 53(5), 2008 (the "explicit complementary filter"; the
same structure as PX4's ``attitude_estimator_q`` and ArduPilot's DCM). With the estimate
q̂ (body → NED), the measured gyro ω_m, the measured specific force f, the measured NED
velocity v (GPS) and a compass heading ψ_c:

* gravity direction measured in body axes d = (R̂ᵀ a − f) / |R̂ᵀ a − f|, where a is the
  NED acceleration from the differentiated velocity (the GPS acceleration compensation of
  ArduPilot's DCM and PX4's ``ATT_ACC_COMP``: a multirotor's accelerometer alone sees the
  thrust direction, not the vertical, while it accelerates); f and a are low-passed alike
  (about 0.1 s);
* estimated one v̂ = R̂ᵀ e_z; correction ω_mes = d × v̂ + wrap(ψ_c − ψ̂) v̂ (tilt, and heading
  about the earth vertical);
* bias estimate ḃ̂ = −k_I ω_mes; q̂̇ = ½ q̂ ⊗ (0, ω_m − b̂ + k_P ω_mes), renormalised.

A constant gyro bias b with k_I = 0 leaves a steady attitude error sin δ = b / k_P on each
axis; with k_I > 0 the bias is learnt (second order, ω_n = √k_I, ζ = k_P / (2√k_I)).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from etsid.sim.body import quat_rate, quat_to_euler, wrap_pi

EST_Q = 0     # estimated quaternion (4)
EST_B = 4     # estimated gyro bias, rad/s (3)
EST_F = 7     # last accelerometer sample, body, m/s^2 (3), written by the engine
EST_FL = 10   # low-passed specific force, body, m/s^2 (3)
EST_V = 13    # low-passed measured NED velocity, m/s (3)
EST_A = 16    # low-passed NED acceleration from the velocity, m/s^2 (3)
N_EST = 19
TAU_V = 0.05  # s, velocity low-pass
TAU_A = 0.05  # s, acceleration low-pass
TAU_F = 0.10  # s, specific-force low-pass (≈ the lag of the two above)


@njit(cache=True)
def mahony_step(est: np.ndarray, gyro: np.ndarray, vel: np.ndarray, yaw_compass: float,
                kp: float, ki: float, dt: float, work: np.ndarray) -> None:
    """Advance the estimator state ``est`` (``N_EST``) by one step of ``dt`` s, in place.

    Parameters
    ----------
    est : ndarray
        Estimator state (layout ``EST_*``); ``est[EST_F:EST_F+3]`` holds the latest
        accelerometer sample (m/s², body FRD).
    gyro : ndarray
        Measured body rate, rad/s (bias and noise included).
    vel : ndarray
        Measured NED velocity, m/s.
    yaw_compass : float
        Measured heading, rad.
    kp, ki : float
        Proportional (rad/s per unit error) and integral (rad/s² per unit error) gains.
    dt : float
        Step, s.
    work : ndarray
        Scratch of 7 floats.
    """
    av = dt / (TAU_V + dt)
    aa = dt / (TAU_A + dt)
    af = dt / (TAU_F + dt)
    for j in range(3):
        v_old = est[EST_V + j]
        v_new = v_old + av * (vel[j] - v_old)
        est[EST_V + j] = v_new
        est[EST_A + j] += aa * ((v_new - v_old) / dt - est[EST_A + j])
        est[EST_FL + j] += af * (est[EST_F + j] - est[EST_FL + j])
    w, x, y, z = est[0], est[1], est[2], est[3]
    # R(q̂) rows; v̂ = third row = the NED down axis in body axes
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r01 = 2.0 * (x * y - w * z)
    r02 = 2.0 * (x * z + w * y)
    r10 = 2.0 * (x * y + w * z)
    r11 = 1.0 - 2.0 * (x * x + z * z)
    r12 = 2.0 * (y * z - w * x)
    vx = 2.0 * (x * z - w * y)
    vy = 2.0 * (y * z + w * x)
    vz = 1.0 - 2.0 * (x * x + y * y)
    ax, ay, az = est[EST_A], est[EST_A + 1], est[EST_A + 2]
    dx = r00 * ax + r10 * ay + vx * az - est[EST_FL]
    dy = r01 * ax + r11 * ay + vy * az - est[EST_FL + 1]
    dz = r02 * ax + r12 * ay + vz * az - est[EST_FL + 2]
    ex = ey = ez = 0.0
    nd = math.sqrt(dx * dx + dy * dy + dz * dz)
    if nd > 1e-6:
        dx, dy, dz = dx / nd, dy / nd, dz / nd
        ex = dy * vz - dz * vy
        ey = dz * vx - dx * vz
        ez = dx * vy - dy * vx
    _, _, yaw = quat_to_euler(est[EST_Q:EST_Q + 4])
    eyaw = wrap_pi(yaw_compass - yaw)
    ex += eyaw * vx
    ey += eyaw * vy
    ez += eyaw * vz
    est[EST_B] -= ki * ex * dt
    est[EST_B + 1] -= ki * ey * dt
    est[EST_B + 2] -= ki * ez * dt
    qdot = work[0:4]
    wc = work[4:7]
    wc[0] = gyro[0] - est[EST_B] + kp * ex
    wc[1] = gyro[1] - est[EST_B + 1] + kp * ey
    wc[2] = gyro[2] - est[EST_B + 2] + kp * ez
    quat_rate(est[EST_Q:EST_Q + 4], wc, qdot)
    n2 = 0.0
    for j in range(4):
        est[EST_Q + j] += dt * qdot[j]
        n2 += est[EST_Q + j] ** 2
    inv = 1.0 / math.sqrt(n2)
    for j in range(4):
        est[EST_Q + j] *= inv


def mahony_reference(est0: np.ndarray, gyro: np.ndarray, force: np.ndarray, vel: np.ndarray,
                     yaw: np.ndarray, kp: float, ki: float, dt: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Plain numpy version of :func:`mahony_step` over a whole record (for tests).

    Parameters
    ----------
    est0 : ndarray
        Initial estimator state (``N_EST``).
    gyro, force, vel : ndarray
        (n, 3) measured rate (rad/s), accelerometer sample (m/s²) and NED velocity (m/s).
    yaw : ndarray
        (n,) compass heading, rad.

    Returns
    -------
    q, bias : ndarray
        (n, 4) estimates and (n, 3) bias estimates after each step.
    """
    q = np.array(est0[EST_Q:EST_Q + 4], dtype=float)
    b = np.array(est0[EST_B:EST_B + 3], dtype=float)
    f_lp = np.array(est0[EST_FL:EST_FL + 3], dtype=float)
    v_lp = np.array(est0[EST_V:EST_V + 3], dtype=float)
    a_lp = np.array(est0[EST_A:EST_A + 3], dtype=float)
    qs, bs = np.empty((len(gyro), 4)), np.empty((len(gyro), 3))
    for i in range(len(gyro)):
        v_new = v_lp + dt / (TAU_V + dt) * (vel[i] - v_lp)
        a_lp = a_lp + dt / (TAU_A + dt) * ((v_new - v_lp) / dt - a_lp)
        v_lp = v_new
        f_lp = f_lp + dt / (TAU_F + dt) * (force[i] - f_lp)
        w, x, y, z = q
        rot = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ])
        d = rot.T @ a_lp - f_lp
        e = np.cross(d / np.linalg.norm(d), rot[2]) if np.linalg.norm(d) > 1e-6 else np.zeros(3)
        yaw_hat = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        e = e + np.angle(np.exp(1j * (yaw[i] - yaw_hat))) * rot[2]
        b = b - ki * e * dt
        wc = gyro[i] - b + kp * e
        qd = 0.5 * np.array([-x * wc[0] - y * wc[1] - z * wc[2], w * wc[0] + y * wc[2] - z * wc[1],
                             w * wc[1] + z * wc[0] - x * wc[2], w * wc[2] + x * wc[1] - y * wc[0]])
        q = q + dt * qd
        q /= np.linalg.norm(q)
        qs[i], bs[i] = q, b
    return qs, bs
