"""State derivative of the multirotor: rotors, ground effect, motors, battery, drag, contact.

All forces are summed in body FRD and rotated to NED with the quaternion's rotation matrix.
See docs/physics.md for every term.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from etsid.sim.body import angular_accel, quat_rate, quat_to_dcm
from etsid.sim.ground import ground_ratio
from etsid.sim.params import (
    ARM,
    C_CONTACT,
    CAP_AH,
    CD0,
    CELLS,
    CG,
    DRAG_L,
    DRAG_Q,
    EFF,
    GE_MAXR,
    GE_MINH,
    GE_MODEL,
    GE_ON,
    GE_TORQUE,
    GEAR_H,
    GRAV,
    J_ROT,
    K_BODY,
    K_CONTACT,
    KAPPA,
    LIFT,
    M_OFF,
    MASS,
    MOUNT_SIN,
    R_INT,
    RADIUS,
    RHO,
    ROTOR_DRAG,
    SAG,
    SIGMA,
    SOC0,
    TAU_DN,
    TAU_M,
    TH0,
    THRUST_SCALE,
    TORQUE_SCALE,
    TWIST,
    V_REF,
    W_IDLE,
    W_MAX,
    WEAK_MOTOR,
    WEAK_SCALE,
    WIND,
    X_OM,
    X_POS,
    X_Q,
    X_SOC,
    X_VEL,
    X_W,
)
from etsid.sim.rotor import ground_effect_torque, rotor_forces

# aux outputs of one derivative evaluation
AUX_F = 0     # specific force, body FRD, m/s^2 (3)
AUX_VBAT = 3  # battery terminal voltage, V
AUX_CUR = 4   # battery current, A
N_AUX = 5
N_WORK = 24


@njit(cache=True)
def derivative(
    x: np.ndarray, mcmd: np.ndarray, P: np.ndarray, inertia: np.ndarray,
    inertia_inv: np.ndarray, rpos: np.ndarray, spin: np.ndarray, dists: np.ndarray,
    lam: np.ndarray, thrust: np.ndarray, torque: np.ndarray, ge: np.ndarray,
    aux: np.ndarray, dx: np.ndarray, work: np.ndarray,
) -> None:
    """Evaluate ẋ for state ``x`` and motor commands ``mcmd`` (0..1), in place.

    Parameters
    ----------
    x : ndarray
        State (see :mod:`etsid.sim.params` for the layout).
    mcmd : ndarray
        Motor commands, 0..1, shape (N,).
    P : ndarray
        Parameter vector from :func:`etsid.sim.params.pack`.
    inertia, inertia_inv : ndarray
        Inertia tensor (kg m²) and its inverse.
    rpos, spin, dists : ndarray
        Hub positions (N,3) m, spin signs (N,), hub distances (N,N) m.
    lam : ndarray
        Induced inflow ratios per rotor: warm start in, solution out.
    thrust, torque, ge : ndarray
        Out: rotor thrust (N), shaft torque (N m), ground-effect ratio per rotor.
    aux : ndarray
        Out: specific force (body, m/s²), battery voltage (V) and current (A).
    dx : ndarray
        Out: state derivative.
    work : ndarray
        Scratch space of ``N_WORK`` floats.
    """
    n = rpos.shape[0]
    # unit quaternion and rotation matrix body -> NED (scratch: no allocation per call)
    qn = 1.0 / math.sqrt(x[X_Q] ** 2 + x[X_Q + 1] ** 2 + x[X_Q + 2] ** 2 + x[X_Q + 3] ** 2)
    q = work[0:4]
    for i in range(4):
        q[i] = x[X_Q + i] * qn
    R = work[4:13].reshape((3, 3))
    quat_to_dcm(q, R)
    w = x[X_W:X_W + 3]
    # air-relative velocity in body axes
    vax = x[X_VEL] - P[WIND]
    vay = x[X_VEL + 1] - P[WIND + 1]
    vaz = x[X_VEL + 2] - P[WIND + 2]
    vb0 = R[0, 0] * vax + R[1, 0] * vay + R[2, 0] * vaz
    vb1 = R[0, 1] * vax + R[1, 1] * vay + R[2, 1] * vaz
    vb2 = R[0, 2] * vax + R[1, 2] * vay + R[2, 2] * vaz
    fb0 = fb1 = fb2 = 0.0
    m0 = m1 = m2 = 0.0
    h2 = 0.0
    power = 0.0
    rad = P[RADIUS]
    cgx, cgy, cgz = P[CG], P[CG + 1], P[CG + 2]
    ge_on = P[GE_ON] > 0.5
    ge_torque = P[GE_TORQUE] > 0.5
    scale_t = P[THRUST_SCALE]
    scale_q = P[TORQUE_SCALE]
    s_mount = P[MOUNT_SIN]
    c_mount = math.sqrt(1.0 - s_mount * s_mount)
    for k in range(n):
        rx, ry, rz = rpos[k, 0] - cgx, rpos[k, 1] - cgy, rpos[k, 2] - cgz  # hub from the CG
        vhx = vb0 + w[1] * rz - w[2] * ry
        vhy = vb1 + w[2] * rx - w[0] * rz
        vhz = vb2 + w[0] * ry - w[1] * rx
        om = x[X_OM + k]
        v_inplane = math.sqrt(vhx * vhx + vhy * vhy)
        t, qa, li = rotor_forces(om, -vhz, v_inplane, P[RHO], rad, P[SIGMA], P[LIFT], P[TH0],
                                 P[TWIST], P[CD0], P[KAPPA], lam[k])
        lam[k] = li
        ratio = 1.0
        if ge_on:
            z_hub = -(x[X_POS + 2] + R[2, 0] * rx + R[2, 1] * ry + R[2, 2] * rz)
            ratio = ground_ratio(z_hub, rad, int(P[GE_MODEL]), dists[k],
                                 math.sqrt(rpos[k, 0] ** 2 + rpos[k, 1] ** 2), P[K_BODY],
                                 P[GE_MINH], P[GE_MAXR])
            if ge_torque:
                qa = ground_effect_torque(t, li, ratio, om, -vhz, v_inplane, P[RHO], rad,
                                          P[SIGMA], P[LIFT], P[CD0], P[KAPPA])
        t *= ratio * scale_t
        qa *= scale_q
        if k == int(P[WEAK_MOTOR]) - 1:
            t *= P[WEAK_SCALE]
            qa *= P[WEAK_SCALE]
        thrust[k] = t
        torque[k] = qa
        ge[k] = ratio
        cd = P[ROTOR_DRAG] * om
        fx = -cd * vhx
        fy = -cd * vhy
        fz = -t
        if s_mount != 0.0:  # the thrust tilted across the arm: a side force and a yaw moment
            arm = math.sqrt(rpos[k, 0] ** 2 + rpos[k, 1] ** 2)
            fx -= t * s_mount * rpos[k, 1] / arm
            fy += t * s_mount * rpos[k, 0] / arm
            fz = -t * c_mount
        fb0 += fx
        fb1 += fy
        fb2 += fz
        m0 += ry * fz - rz * fy
        m1 += rz * fx - rx * fz
        m2 += rx * fy - ry * fx
        h2 -= spin[k] * P[J_ROT] * om
        power += qa * om
    # battery: open-circuit voltage, internal resistance sag
    soc = x[X_SOC] if P[SAG] > 0.5 else P[SOC0]
    voc = P[CELLS] * (3.5 + 0.7 * soc)
    cur = max(power, 0.0) / (P[EFF] * voc)
    vbat = voc - P[R_INT] * cur if P[SAG] > 0.5 else voc
    aux[AUX_VBAT] = vbat
    aux[AUX_CUR] = cur
    # motors: first-order lag towards the commanded speed (scaled by battery voltage)
    wtop = P[W_MAX] * vbat / P[V_REF]
    tau_up = P[TAU_M]
    tau_dn = P[TAU_DN]
    asymmetric = tau_dn != tau_up
    for k in range(n):
        m = mcmd[k]
        m = 0.0 if m < 0.0 else (1.0 if m > 1.0 else m)
        wss = P[W_IDLE] + (wtop - P[W_IDLE]) * m
        tau = tau_up
        if asymmetric and wss <= x[X_OM + k]:  # predictable branch when symmetric
            tau = tau_dn
        omd = (wss - x[X_OM + k]) / tau
        dx[X_OM + k] = omd
        m2 += spin[k] * (torque[k] + P[J_ROT] * omd)
    # body drag, acting at the geometric centre (-cg from the CG), and a constant moment
    fd0 = -(P[DRAG_L] * vb0 + P[DRAG_Q] * abs(vb0) * vb0)
    fd1 = -(P[DRAG_L + 1] * vb1 + P[DRAG_Q + 1] * abs(vb1) * vb1)
    fd2 = -(P[DRAG_L + 2] * vb2 + P[DRAG_Q + 2] * abs(vb2) * vb2)
    fb0 += fd0
    fb1 += fd1
    fb2 += fd2
    if cgx != 0.0 or cgy != 0.0 or cgz != 0.0:
        m0 -= cgy * fd2 - cgz * fd1
        m1 -= cgz * fd0 - cgx * fd2
        m2 -= cgx * fd1 - cgy * fd0
    m0 += P[M_OFF]
    m1 += P[M_OFF + 1]
    m2 += P[M_OFF + 2]
    # ground contact: spring-damper under the CG, viscous friction, rotational damping
    fc0 = fc1 = fc2 = 0.0
    pen = P[GEAR_H] + x[X_POS + 2]
    if pen > 0.0:
        fup = P[K_CONTACT] * pen + P[C_CONTACT] * x[X_VEL + 2]
        if fup > 0.0:
            fc2 = -fup
        grip = min(pen / 0.01, 1.0)
        fc0 = -P[C_CONTACT] * grip * x[X_VEL]
        fc1 = -P[C_CONTACT] * grip * x[X_VEL + 1]
        crot = 0.5 * P[C_CONTACT] * P[ARM] * P[ARM] * grip
        m0 -= crot * w[0]
        m1 -= crot * w[1]
        m2 -= crot * w[2]
    inv_m = 1.0 / P[MASS]
    fb = work[13:16]
    fb[0], fb[1], fb[2] = fb0, fb1, fb2
    for i in range(3):
        dx[X_POS + i] = x[X_VEL + i]
        dx[X_VEL + i] = (R[i, 0] * fb0 + R[i, 1] * fb1 + R[i, 2] * fb2) * inv_m
        aux[AUX_F + i] = (fb[i] + R[0, i] * fc0 + R[1, i] * fc1 + R[2, i] * fc2) * inv_m
    dx[X_VEL] += fc0 * inv_m
    dx[X_VEL + 1] += fc1 * inv_m
    dx[X_VEL + 2] += fc2 * inv_m + P[GRAV]
    quat_rate(q, w, dx[X_Q:X_Q + 4])
    mom = work[16:19]
    mom[0], mom[1], mom[2] = m0, m1, m2
    hrot = work[19:22]
    hrot[0], hrot[1], hrot[2] = 0.0, 0.0, h2
    angular_accel(w, mom, hrot, inertia, inertia_inv, dx[X_W:X_W + 3])
    dx[X_SOC] = -cur / (3600.0 * P[CAP_AH]) if P[SAG] > 0.5 else 0.0
