"""Rigid body: quaternion kinematics, Newton–Euler rotation with a full inertia tensor.

Quaternions are scalar-first, q = (w, x, y, z), rotating body FRD vectors into the
NED world frame: v_ned = R(q) v_body. Kinematics q̇ = ½ q ⊗ (0, ω);
Euler: J ω̇ = M − ω × (J ω + h), with h the angular momentum of the spinning rotors.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def quat_to_dcm(q: np.ndarray, out: np.ndarray) -> None:
    """Write the rotation matrix body→world of unit quaternion ``q`` into ``out`` (3×3)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    out[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    out[0, 1] = 2.0 * (x * y - w * z)
    out[0, 2] = 2.0 * (x * z + w * y)
    out[1, 0] = 2.0 * (x * y + w * z)
    out[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    out[1, 2] = 2.0 * (y * z - w * x)
    out[2, 0] = 2.0 * (x * z - w * y)
    out[2, 1] = 2.0 * (y * z + w * x)
    out[2, 2] = 1.0 - 2.0 * (x * x + y * y)


@njit(cache=True)
def quat_to_euler(q: np.ndarray) -> tuple[float, float, float]:
    """ZYX Euler angles (roll, pitch, yaw), rad, yaw in (−π, π]."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    s = 2.0 * (w * y - z * x)
    s = 1.0 if s > 1.0 else (-1.0 if s < -1.0 else s)
    pitch = math.asin(s)
    yaw = wrap_pi(math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))
    return roll, pitch, yaw


@njit(cache=True)
def euler_to_quat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of ZYX Euler angles in rad."""
    cr, sr = math.cos(0.5 * roll), math.sin(0.5 * roll)
    cp, sp = math.cos(0.5 * pitch), math.sin(0.5 * pitch)
    cy, sy = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
    return np.array([
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ])


@njit(cache=True)
def wrap_pi(a: float) -> float:
    """Wrap an angle to (−π, π], rad."""
    two_pi = 2.0 * math.pi
    a = a - two_pi * math.floor((a + math.pi) / two_pi)
    return math.pi if a <= -math.pi else a


@njit(cache=True)
def quat_rate(q: np.ndarray, w: np.ndarray, out: np.ndarray) -> None:
    """q̇ = ½ q ⊗ (0, ω) for body rate ω (rad/s); written into ``out`` (4,)."""
    out[0] = 0.5 * (-q[1] * w[0] - q[2] * w[1] - q[3] * w[2])
    out[1] = 0.5 * (q[0] * w[0] + q[2] * w[2] - q[3] * w[1])
    out[2] = 0.5 * (q[0] * w[1] + q[3] * w[0] - q[1] * w[2])
    out[3] = 0.5 * (q[0] * w[2] + q[1] * w[1] - q[2] * w[0])


@njit(cache=True)
def angular_accel(
    w: np.ndarray, moment: np.ndarray, h_rot: np.ndarray, inertia: np.ndarray,
    inertia_inv: np.ndarray, out: np.ndarray
) -> None:
    """ω̇ = J⁻¹ (M − ω × (J ω + h)), rad/s², written into ``out`` (3,).

    Parameters
    ----------
    w : ndarray
        Body rate ω, rad/s.
    moment : ndarray
        External moment about the CG in body axes, N m.
    h_rot : ndarray
        Angular momentum of the rotors relative to the body, N m s.
    inertia, inertia_inv : ndarray
        Full inertia tensor J (kg m², products of inertia included) and its inverse.
    """
    hx = inertia[0, 0] * w[0] + inertia[0, 1] * w[1] + inertia[0, 2] * w[2] + h_rot[0]
    hy = inertia[1, 0] * w[0] + inertia[1, 1] * w[1] + inertia[1, 2] * w[2] + h_rot[1]
    hz = inertia[2, 0] * w[0] + inertia[2, 1] * w[1] + inertia[2, 2] * w[2] + h_rot[2]
    mx = moment[0] - (w[1] * hz - w[2] * hy)
    my = moment[1] - (w[2] * hx - w[0] * hz)
    mz = moment[2] - (w[0] * hy - w[1] * hx)
    for i in range(3):
        out[i] = inertia_inv[i, 0] * mx + inertia_inv[i, 1] * my + inertia_inv[i, 2] * mz


@njit(cache=True)
def free_body(
    q0: np.ndarray, w0: np.ndarray, inertia: np.ndarray, dt: float, n_steps: int
) -> tuple[np.ndarray, np.ndarray]:
    """Integrate a torque-free rigid body with RK4 (same kernels as the flight engine).

    Returns
    -------
    q : ndarray
        Quaternions, shape (n_steps + 1, 4), normalised after every step.
    w : ndarray
        Body rates, shape (n_steps + 1, 3), rad/s.
    """
    jinv = np.linalg.inv(inertia)
    zero = np.zeros(3)
    qs = np.empty((n_steps + 1, 4))
    ws = np.empty((n_steps + 1, 3))
    qs[0] = q0 / np.sqrt(np.sum(q0 * q0))
    ws[0] = w0
    kq = np.empty((4, 4))
    kw = np.empty((4, 3))
    qt = np.empty(4)
    wt = np.empty(3)
    for n in range(n_steps):
        for s in range(4):
            c = 0.0 if s == 0 else (0.5 * dt if s < 3 else dt)
            for i in range(4):
                qt[i] = qs[n, i] + (c * kq[s - 1, i] if s > 0 else 0.0)
            for i in range(3):
                wt[i] = ws[n, i] + (c * kw[s - 1, i] if s > 0 else 0.0)
            quat_rate(qt, wt, kq[s])
            angular_accel(wt, zero, zero, inertia, jinv, kw[s])
        for i in range(4):
            qs[n + 1, i] = qs[n, i] + dt / 6.0 * (kq[0, i] + 2 * kq[1, i] + 2 * kq[2, i] + kq[3, i])
        for i in range(3):
            ws[n + 1, i] = ws[n, i] + dt / 6.0 * (kw[0, i] + 2 * kw[1, i] + 2 * kw[2, i] + kw[3, i])
        qs[n + 1] /= np.sqrt(np.sum(qs[n + 1] * qs[n + 1]))
    return qs, ws
