"""Compiled helpers of replay: many independent runs in parallel, rotor-speed history.

:func:`advance_jobs` flies independent runs (candidate vehicles × re-initialised horizons)
over shared per-step inputs with numba ``prange``; :func:`motor_speed_history` turns
recorded motor outputs into the rotor speeds the vehicle's motor model gives.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from etsid.sim.engine import advance
from etsid.sim.params import TAU_DN, TAU_M, V_REF, W_IDLE, W_MAX


@njit(cache=True)
def motor_speed_history(m: np.ndarray, vbat: np.ndarray, P: np.ndarray, dt: float
                        ) -> np.ndarray:
    """Rotor speeds (rad/s) the vehicle's motor model gives for recorded motor outputs.

    Parameters
    ----------
    m : ndarray
        (n, N) motor outputs 0..1 at a constant period ``dt`` (s).
    vbat : ndarray
        (n,) battery voltage, V (sets the top speed Ω_max V / V_ref).
    P : ndarray
        Parameter vector (idle and top speed, spin-up/spin-down time constants, delay in
        physics steps is ignored here: shift ``m`` first).

    Returns
    -------
    ndarray
        (n, N): Ω starts at the steady speed of the first command and follows the
        first-order lag exactly over each held sample (asymmetric time constants).
    """
    n, k = m.shape
    out = np.empty((n, k))
    eu = math.exp(-dt / P[TAU_M])
    ed = math.exp(-dt / P[TAU_DN])
    for i in range(n):
        top = P[W_MAX] * vbat[i] / P[V_REF]
        for j in range(k):
            c = min(max(m[i, j], 0.0), 1.0)
            wss = P[W_IDLE] + (top - P[W_IDLE]) * c
            if i == 0:
                out[i, j] = wss
            else:
                w = out[i - 1, j]
                e = eu if wss > w else ed
                out[i, j] = wss + (w - wss) * e
    return out


@njit(parallel=True, cache=True)
def advance_jobs(
    S0: np.ndarray, P: np.ndarray, inertia: np.ndarray, rpos: np.ndarray, spin: np.ndarray,
    dists: np.ndarray, mix: np.ndarray, job_run: np.ndarray, job_start: np.ndarray,
    job_stop: np.ndarray, exc: np.ndarray, alt_sp: np.ndarray, alt_rate: np.ndarray,
    vel_sp: np.ndarray, thr: np.ndarray, motors: np.ndarray, noise: np.ndarray, k_out: int,
    rf_every: int, meas: np.ndarray, truth: np.ndarray,
) -> None:
    """Fly independent jobs in parallel: job j starts from ``S0[j]`` with ``P[j]``,
    ``inertia[j]`` and flies physics steps ``job_start[j]:job_stop[j]`` of the shared
    per-step inputs, recording into ``meas[job_run[j]]`` / ``truth[job_run[j]]`` rows
    ``job_start[j] // k_out`` on (``job_start`` multiples of ``k_out``)."""
    for j in prange(S0.shape[0]):
        a = job_start[j]
        b = job_stop[j]
        r0 = a // k_out
        r1 = (b + k_out - 1) // k_out
        S = S0[j].copy()
        mot = motors[a:b] if motors.shape[0] > 0 else motors
        advance(S, P[j], inertia[j], rpos, spin, dists, mix, exc[a:b], alt_sp[a:b],
                alt_rate[a:b], vel_sp[a:b], thr[a:b], mot, noise[a:b], k_out, rf_every,
                meas[job_run[j], r0:r1], truth[job_run[j], r0:r1])
