"""Frame conversions from ROS REP-103 (FLU body, ENU world) to PX4/MAVLink (FRD body, NED world).

With A the ENU↔NED swap (x↔y, z negated) and B = diag(1, −1, −1) the FLU↔FRD flip,
R_ned_frd = A · R_enu_flu · B. Body vectors (rates, specific force) map by B, world
vectors (positions, velocities) by A.
"""

from __future__ import annotations

import numpy as np

ENU_TO_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
FLU_TO_FRD = np.diag([1.0, -1.0, -1.0])


def flu_to_frd(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, ...]:
    """Body vector components FLU → FRD (y and z negated)."""
    return x, -y, -z


def enu_to_ned(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, ...]:
    """World vector components ENU → NED (north = y, east = x, down = −z)."""
    return y, x, -z


def quat_to_matrix(w: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) from unit quaternions (normalised here).

    A quaternion from damaged bytes (huge, infinite or NaN components) gives a NaN matrix,
    not a numpy warning; the plausibility limits drop it downstream.
    """
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _quat_to_matrix(w, x, y, z)


def _normalised(w: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    n = np.sqrt(w * w + x * x + y * y + z * z)
    n = np.where(n > 0, n, 1.0)
    n = np.where(np.isfinite(n), n, np.nan)  # an overflowing quaternion has no rotation
    return w / n, x / n, y / n, z / n


def _quat_to_matrix(w: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    w, x, y, z = _normalised(w, x, y, z)
    r = np.empty((np.size(w), 3, 3))
    r[:, 0, 0] = 1 - 2 * (y * y + z * z)
    r[:, 0, 1] = 2 * (x * y - w * z)
    r[:, 0, 2] = 2 * (x * z + w * y)
    r[:, 1, 0] = 2 * (x * y + w * z)
    r[:, 1, 1] = 1 - 2 * (x * x + z * z)
    r[:, 1, 2] = 2 * (y * z - w * x)
    r[:, 2, 0] = 2 * (x * z - w * y)
    r[:, 2, 1] = 2 * (y * z + w * x)
    r[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def matrix_to_euler(r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ZYX Euler angles (roll, pitch, yaw), rad, of world-from-body matrices (N, 3, 3)."""
    return _euler(r[:, 2, 1], r[:, 2, 2], r[:, 2, 0], r[:, 1, 0], r[:, 0, 0])


def _euler(r21: np.ndarray, r22: np.ndarray, r20: np.ndarray, r10: np.ndarray,
           r00: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`matrix_to_euler` from the five entries it reads."""
    roll = np.arctan2(r21, r22)
    pitch = -np.arcsin(np.clip(r20, -1.0, 1.0))
    yaw = np.arctan2(r10, r00)
    return roll, pitch, yaw


def quat_to_euler(
    w: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ZYX Euler angles of a world-from-body quaternion in the same convention (e.g. NED/FRD).

    ``matrix_to_euler(quat_to_matrix(w, x, y, z))``, computing only the five entries of the
    matrix it reads, with the same arithmetic (the whole matrices took 26 of 30 ms for
    150,000 quaternions)."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        w, x, y, z = _normalised(w, x, y, z)
        r00 = 1 - 2 * (y * y + z * z)
        r10 = 2 * (x * y + w * z)
        r20 = 2 * (x * z - w * y)
        r21 = 2 * (y * z + w * x)
        r22 = 1 - 2 * (x * x + y * y)
    return _euler(r21, r22, r20, r10, r00)


def enu_flu_quat_to_ned_frd_euler(
    w: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll, pitch, yaw (rad, FRD in NED) of an ENU-from-FLU orientation quaternion (ROS)."""
    r = ENU_TO_NED @ quat_to_matrix(w, x, y, z) @ FLU_TO_FRD
    return matrix_to_euler(r)


def euler_to_quat(
    roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """World-from-body quaternion (w, x, y, z) of ZYX Euler angles, rad."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    w = cr * cp * cy + sr * sp * sy
    x = sr * cp * cy - cr * sp * sy
    y = cr * sp * cy + sr * cp * sy
    z = cr * cp * sy - sr * sp * cy
    return w, x, y, z


def matrix_to_quat(r: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Unit quaternions (w, x, y, z) of rotation matrices (N, 3, 3), w ≥ 0."""
    roll, pitch, yaw = matrix_to_euler(r)
    w, x, y, z = euler_to_quat(roll, pitch, yaw)
    sign = np.where(w < 0, -1.0, 1.0)
    return w * sign, x * sign, y * sign, z * sign


def ned_frd_euler_to_enu_flu_quat(
    roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """ENU-from-FLU quaternion (w, x, y, z) as MAVROS publishes it, from NED/FRD Euler angles."""
    r_ned_frd = quat_to_matrix(*euler_to_quat(np.atleast_1d(roll), np.atleast_1d(pitch),
                                              np.atleast_1d(yaw)))
    r_enu_flu = ENU_TO_NED.T @ r_ned_frd @ FLU_TO_FRD.T
    return matrix_to_quat(r_enu_flu)
