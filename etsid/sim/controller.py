"""Flight controller and simulated pilot, one numba step per control period.

Cascade as in PX4/ArduPilot "angle" (stabilise) mode with altitude hold:

* pilot: sticks = low-passed velocity/heading corrections (a pilot keeping the vehicle
  over the spot or at a forward speed) + the excitation of the scenario, clipped to ±1;
* angle loop: roll/pitch stick → angle setpoint (± max tilt), yaw stick → yaw-rate
  setpoint; Euler-angle errors × ``angle_kp`` → Euler rates → body-rate setpoints;
* rate loop: PID per axis on the measured gyro (D on a low-passed measurement),
  normalised torque demands −1..1;
* altitude hold: rangefinder altitude → climb-rate setpoint → PI on the measured vertical
  speed around the hover collective, with tilt compensation;
* mixer: motor = collective + Σ (mixer coefficient × torque demand), desaturated by a
  common shift and clipped to 0..1.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from etsid.sim.body import wrap_pi
from etsid.sim.params import (
    ALT_HOLD,
    ALT_KP,
    ANGLE_KP,
    DCUT,
    DT,
    LOOP_INPUT,
    LOOP_RATES,
    LOOP_TORQUE,
    MAX_CLIMB,
    MAX_RATE,
    MAX_TILT,
    MAX_YAW_RATE,
    PILOT_KI,
    PILOT_KPSI,
    PILOT_KV,
    PILOT_TAU,
    RATE_KD,
    RATE_KI,
    RATE_KP,
    THR_HOVER,
    VZ_KI,
    VZ_KP,
    YAW_MIX,
)

# controller state layout
CS_IRATE = 0   # rate integrators (3)
CS_GF = 3      # low-passed gyro for the D term (3)
CS_IVZ = 6     # climb-rate integrator
CS_PIX = 7     # pilot integrators forward/right (2)
CS_PU = 9      # pilot stick outputs roll, pitch, yaw (3)
CS_YAW0 = 12   # pilot heading reference, rad
CS_INIT = 13   # 0 until the first step has run
CS_TAU = 14    # last torque demands roll, pitch, yaw (3)
N_CS = 17

# measurement vector layout handed to the controller
MS_GYRO = 0    # p q r, rad/s
MS_ATT = 3     # roll pitch yaw, rad
MS_VEL = 6     # vx vy vz NED, m/s
MS_ALT = 9     # rangefinder altitude, m
N_MS = 10

INT_LIMIT = 0.3
PILOT_LIMIT = 0.6


@njit(cache=True)
def _clip(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else (hi if v > hi else v)


@njit(cache=True)
def control_step(
    P: np.ndarray, cs: np.ndarray, ms: np.ndarray, exc: np.ndarray, alt_sp: float,
    alt_rate: float, vel_sp: np.ndarray, thr_manual: float, mix: np.ndarray,
    m_out: np.ndarray, u_out: np.ndarray, sp_out: np.ndarray,
) -> None:
    """Run pilot, angle, rate and altitude loops and the mixer for one control period.

    Parameters
    ----------
    P : ndarray
        Parameter vector (:mod:`etsid.sim.params`).
    cs : ndarray
        Controller state (``N_CS``), updated in place.
    ms : ndarray
        Measurements: gyro (rad/s), Euler angles (rad), NED velocity (m/s), altitude (m).
    exc : ndarray
        Loop commands, read as ``P[LOOP_INPUT]`` says: excitation added to the roll, pitch,
        yaw sticks (−1..1, default); body-rate setpoints (rad/s, pilot and angle loop
        bypassed); or torque demands (−1..1, rate loop bypassed too). In the last two
        modes ``u_out[:3]`` echoes them.
    alt_sp, alt_rate : float
        Altitude setpoint (m) and its rate (m/s, feed-forward).
    vel_sp : ndarray
        Pilot's target forward and rightward speed in the heading frame, m/s.
    thr_manual : float
        Collective (0..1) used when altitude hold is off.
    mix : ndarray
        Mixer (N, 4): thrust, roll, pitch, yaw coefficient per motor.
    m_out, u_out, sp_out : ndarray
        Out: motor commands (N), sticks u_roll u_pitch u_yaw u_thrust, rate setpoints (rad/s).
    """
    roll, pitch, yaw = ms[MS_ATT], ms[MS_ATT + 1], ms[MS_ATT + 2]
    if cs[CS_INIT] < 0.5:
        cs[CS_YAW0] = yaw
        for i in range(3):
            cs[CS_GF + i] = ms[MS_GYRO + i]
        cs[CS_INIT] = 1.0
    mode = int(P[LOOP_INPUT])
    cr = math.cos(roll)
    cp = math.cos(pitch)
    tau = cs[CS_TAU:CS_TAU + 3]
    if mode in (LOOP_RATES, LOOP_TORQUE):
        for i in range(3):
            u_out[i] = exc[i]
            sp_out[i] = exc[i] if mode == LOOP_RATES else 0.0
        if mode == LOOP_RATES:
            _rate_loop(P, cs, ms, sp_out, tau)
        else:
            for i in range(3):
                tau[i] = exc[i]
            _clip_torque(P, tau)
    else:
        _pilot_and_angle_loop(P, cs, ms, exc, vel_sp, u_out, sp_out)
        _rate_loop(P, cs, ms, sp_out, tau)
    _altitude_and_mixer(P, cs, ms, alt_sp, alt_rate, thr_manual, cr * cp, tau, mix, m_out,
                        u_out)


@njit(cache=True)
def _pilot_and_angle_loop(P: np.ndarray, cs: np.ndarray, ms: np.ndarray, exc: np.ndarray,
                          vel_sp: np.ndarray, u_out: np.ndarray, sp_out: np.ndarray) -> None:
    dt = P[DT]
    roll, pitch, yaw = ms[MS_ATT], ms[MS_ATT + 1], ms[MS_ATT + 2]
    # --- pilot ---------------------------------------------------------------------------
    cy, sy = math.cos(yaw), math.sin(yaw)
    vf = cy * ms[MS_VEL] + sy * ms[MS_VEL + 1]
    vr = -sy * ms[MS_VEL] + cy * ms[MS_VEL + 1]
    ef = vel_sp[0] - vf
    er = vel_sp[1] - vr
    cs[CS_PIX] = _clip(cs[CS_PIX] + ef * dt, -20.0, 20.0)
    cs[CS_PIX + 1] = _clip(cs[CS_PIX + 1] + er * dt, -20.0, 20.0)
    want_roll = _clip(P[PILOT_KV] * er + P[PILOT_KI] * cs[CS_PIX + 1], -PILOT_LIMIT, PILOT_LIMIT)
    want_pitch = _clip(-(P[PILOT_KV] * ef + P[PILOT_KI] * cs[CS_PIX]), -PILOT_LIMIT, PILOT_LIMIT)
    want_yaw = _clip(-P[PILOT_KPSI] * wrap_pi(yaw - cs[CS_YAW0]), -PILOT_LIMIT, PILOT_LIMIT)
    a = dt / (P[PILOT_TAU] + dt)
    cs[CS_PU] += a * (want_roll - cs[CS_PU])
    cs[CS_PU + 1] += a * (want_pitch - cs[CS_PU + 1])
    cs[CS_PU + 2] += a * (want_yaw - cs[CS_PU + 2])
    for i in range(3):
        u_out[i] = _clip(cs[CS_PU + i] + exc[i], -1.0, 1.0)
    # --- angle loop ------------------------------------------------------------------------
    roll_sp = u_out[0] * P[MAX_TILT]
    pitch_sp = u_out[1] * P[MAX_TILT]
    droll = P[ANGLE_KP] * (roll_sp - roll)
    dpitch = P[ANGLE_KP] * (pitch_sp - pitch)
    dyaw = u_out[2] * P[MAX_YAW_RATE]
    sr, cr = math.sin(roll), math.cos(roll)
    sp_, cp = math.sin(pitch), math.cos(pitch)
    mr = P[MAX_RATE]
    sp_out[0] = _clip(droll - dyaw * sp_, -mr, mr)
    sp_out[1] = _clip(dpitch * cr + dyaw * cp * sr, -mr, mr)
    sp_out[2] = _clip(-dpitch * sr + dyaw * cp * cr, -P[MAX_YAW_RATE], P[MAX_YAW_RATE])


@njit(cache=True)
def _rate_loop(P: np.ndarray, cs: np.ndarray, ms: np.ndarray, sp_out: np.ndarray,
               tau: np.ndarray) -> None:
    dt = P[DT]
    ad = dt / (1.0 / (2.0 * math.pi * P[DCUT]) + dt)
    for i in range(3):
        g = ms[MS_GYRO + i]
        gf_old = cs[CS_GF + i]
        gf = gf_old + ad * (g - gf_old)
        cs[CS_GF + i] = gf
        e = sp_out[i] - g
        cs[CS_IRATE + i] = _clip(cs[CS_IRATE + i] + P[RATE_KI + i] * e * dt, -INT_LIMIT, INT_LIMIT)
        tau[i] = P[RATE_KP + i] * e + cs[CS_IRATE + i] - P[RATE_KD + i] * (gf - gf_old) / dt
    _clip_torque(P, tau)


@njit(cache=True)
def _clip_torque(P: np.ndarray, tau: np.ndarray) -> None:
    tau[0] = _clip(tau[0], -1.0, 1.0)
    tau[1] = _clip(tau[1], -1.0, 1.0)
    tau[2] = _clip(tau[2], -P[YAW_MIX], P[YAW_MIX])


@njit(cache=True)
def _altitude_and_mixer(P: np.ndarray, cs: np.ndarray, ms: np.ndarray, alt_sp: float,
                        alt_rate: float, thr_manual: float, crcp: float, tau: np.ndarray,
                        mix: np.ndarray, m_out: np.ndarray, u_out: np.ndarray) -> None:
    dt = P[DT]
    # --- altitude hold ---------------------------------------------------------------------
    if P[ALT_HOLD] > 0.5:
        climb_sp = _clip(P[ALT_KP] * (alt_sp - ms[MS_ALT]) + alt_rate, -P[MAX_CLIMB],
                         P[MAX_CLIMB])
        ev = climb_sp + ms[MS_VEL + 2]  # climb rate = -vz
        cs[CS_IVZ] = _clip(cs[CS_IVZ] + P[VZ_KI] * ev * dt, -INT_LIMIT, INT_LIMIT)
        tilt = max(crcp, 0.7)
        thr = _clip((P[THR_HOVER] + P[VZ_KP] * ev + cs[CS_IVZ]) / tilt, 0.05, 0.95)
    else:
        thr = _clip(thr_manual, 0.0, 1.0)
    u_out[3] = thr
    # --- mixer -----------------------------------------------------------------------------
    n = mix.shape[0]
    hi = -1e9
    lo = 1e9
    for k in range(n):
        m = thr + mix[k, 1] * tau[0] + mix[k, 2] * tau[1] + mix[k, 3] * tau[2]
        m_out[k] = m
        hi = max(hi, m)
        lo = min(lo, m)
    shift = 0.0
    if hi > 1.0 and lo > 0.0:
        shift = -min(hi - 1.0, lo)
    elif lo < 0.0 and hi < 1.0:
        shift = min(-lo, 1.0 - hi)
    for k in range(n):
        m_out[k] = _clip(m_out[k] + shift, 0.0, 1.0)
