"""Attitude estimator of the kind autopilots run: Mahony's explicit complementary filter.

Mahony, Hamel & Pflimlin, *Nonlinear complementary filters on the special orthogonal
group*, IEEE Trans. Automatic Control 53(5), 2008 (the "explicit complementary filter"; the
same structure as PX4's ``attitude_estimator_q`` and ArduPilot's DCM). With the estimate
q̂ (body → NED), the measured gyro ω_m, the measured specific force f and a compass
heading ψ_c:

* estimated down direction in body axes v̂ = R̂ᵀ e_z; measured one v = −f / |f|;
* correction ω_mes = v × v̂ + wrap(ψ_c − ψ̂) v̂ (tilt from the accelerometer, heading
  about the earth vertical from the compass);
* bias estimate ḃ̂ = −k_I ω_mes; q̂̇ = ½ q̂ ⊗ (0, ω_m − b̂ + k_P ω_mes), renormalised.

A constant gyro bias b with k_I = 0 leaves a steady attitude error sin δ = b / k_P on each
axis; with k_I > 0 the bias is learnt with time constant ≈ k_P / k_I.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from etsid.sim.body import quat_rate, quat_to_euler, wrap_pi

EST_Q = 0     # estimated quaternion (4)
EST_B = 4     # estimated gyro bias, rad/s (3)
EST_F = 7     # last measured specific force, body, m/s^2 (3)
N_EST = 10


@njit(cache=True)
def mahony_step(est: np.ndarray, gyro: np.ndarray, yaw_compass: float, kp: float, ki: float,
                dt: float, work: np.ndarray) -> None:
    """Advance the estimator state ``est`` (``N_EST``) by one step of ``dt`` s, in place.

    Parameters
    ----------
    est : ndarray
        q̂ (4), b̂ (3, rad/s), last specific-force sample f (3, m/s², body FRD).
    gyro : ndarray
        Measured body rate, rad/s (bias and noise included).
    yaw_compass : float
        Measured heading, rad.
    kp, ki : float
        Proportional (rad/s per unit error) and integral (rad/s² per unit error) gains.
    dt : float
        Step, s.
    work : ndarray
        Scratch of 7 floats.
    """
    w, x, y, z = est[0], est[1], est[2], est[3]
    # third row of R(q̂): the NED down axis seen in body axes
    vx = 2.0 * (x * z - w * y)
    vy = 2.0 * (y * z + w * x)
    vz = 1.0 - 2.0 * (x * x + y * y)
    ex = ey = ez = 0.0
    fx, fy, fz = est[EST_F], est[EST_F + 1], est[EST_F + 2]
    nf = math.sqrt(fx * fx + fy * fy + fz * fz)
    if nf > 1e-6:
        mx, my, mz = -fx / nf, -fy / nf, -fz / nf
        ex = my * vz - mz * vy
        ey = mz * vx - mx * vz
        ez = mx * vy - my * vx
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


def mahony_reference(q0: np.ndarray, gyro: np.ndarray, force: np.ndarray, yaw: np.ndarray,
                     kp: float, ki: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Plain numpy version of :func:`mahony_step` over a whole record (for tests).

    Parameters
    ----------
    q0 : ndarray
        Initial estimate (w, x, y, z).
    gyro, force : ndarray
        (n, 3) measured rate (rad/s) and specific force (m/s²) used at each step.
    yaw : ndarray
        (n,) compass heading, rad.

    Returns
    -------
    q, bias : ndarray
        (n, 4) estimates and (n, 3) bias estimates after each step.
    """
    q = np.asarray(q0, dtype=float).copy()
    b = np.zeros(3)
    qs, bs = np.empty((len(gyro), 4)), np.empty((len(gyro), 3))
    for i in range(len(gyro)):
        w, x, y, z = q
        v_hat = np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])
        f = force[i]
        e = np.zeros(3)
        if np.linalg.norm(f) > 1e-6:
            e = np.cross(-f / np.linalg.norm(f), v_hat)
        yaw_hat = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        e = e + np.angle(np.exp(1j * (yaw[i] - yaw_hat))) * v_hat
        b = b - ki * e * dt
        wc = gyro[i] - b + kp * e
        qd = 0.5 * np.array([-x * wc[0] - y * wc[1] - z * wc[2], w * wc[0] + y * wc[2] - z * wc[1],
                             w * wc[1] + z * wc[0] - x * wc[2], w * wc[2] + x * wc[1] - y * wc[0]])
        q = q + dt * qd
        q /= np.linalg.norm(q)
        qs[i], bs[i] = q, b
    return qs, bs
