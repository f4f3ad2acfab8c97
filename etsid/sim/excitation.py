"""Pilot-like stick excitation for identification flights (all signals normalised −1..1).

Building blocks, each a plain numpy function of the time vector:

* :func:`multisine` — Schroeder-phased sum of sines on a frequency comb; the three
  axes get interleaved combs (orthogonal over one period), as in multi-axis flight tests;
* :func:`chirp` — logarithmic frequency sweep inside a window, with cosine tapers;
* :func:`filtered_noise` — Butterworth-filtered Gaussian noise, unit standard deviation;
* :func:`steps` — held stick steps (for step-response checks).

:func:`stick_excitation` mixes them into the (n, 3) roll/pitch/yaw excitation of a flight.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, sosfilt

EXCITATIONS = ("mixed", "multisine", "chirp", "noise", "steps", "none")
MULTISINE_PERIOD = 20.0  # s, frequency resolution 0.05 Hz


def multisine(t: np.ndarray, freqs: np.ndarray, amps: np.ndarray | None = None) -> np.ndarray:
    """Schroeder-phased multisine, scaled to peak 1.

    Parameters
    ----------
    t : ndarray
        Time, s.
    freqs : ndarray
        Component frequencies, Hz.
    amps : ndarray, optional
        Relative amplitudes (default all 1).

    Returns
    -------
    ndarray
        Signal with max |s| = 1 over ``t``.
    """
    freqs = np.asarray(freqs, dtype=float)
    amps = np.ones_like(freqs) if amps is None else np.asarray(amps, dtype=float)
    k = np.arange(1, freqs.size + 1)
    power = amps**2 / np.sum(amps**2)
    phases = -2.0 * np.pi * np.cumsum(k * power)  # Schroeder (1970) for a general spectrum
    s = np.zeros_like(t)
    for f, a, ph in zip(freqs, amps, phases, strict=True):
        s += a * np.cos(2.0 * np.pi * f * t + ph)
    peak = np.max(np.abs(s))
    return s / peak if peak > 0 else s


def chirp(t: np.ndarray, f0: float, f1: float, t0: float, t1: float, taper: float = 1.0
          ) -> np.ndarray:
    """Logarithmic sweep from ``f0`` to ``f1`` Hz between ``t0`` and ``t1`` s, zero outside.

    The amplitude is 1 with raised-cosine ramps of ``taper`` s at both ends.
    """
    s = np.zeros_like(t)
    inside = (t >= t0) & (t < t1)
    if t1 <= t0 or not np.any(inside):
        return s
    tau = t[inside] - t0
    span = t1 - t0
    ratio = f1 / f0
    phase = 2.0 * np.pi * f0 * span / np.log(ratio) * (ratio ** (tau / span) - 1.0)
    env = np.ones_like(tau)
    if taper > 0:
        env = np.minimum(env, 0.5 - 0.5 * np.cos(np.pi * np.clip(tau / taper, 0, 1)))
        env = np.minimum(env, 0.5 - 0.5 * np.cos(np.pi * np.clip((span - tau) / taper, 0, 1)))
    s[inside] = env * np.sin(phase)
    return s


def filtered_noise(n: int, dt: float, cutoff_hz: float, rng: np.random.Generator) -> np.ndarray:
    """Gaussian noise through a 2nd-order Butterworth low-pass, scaled to unit std."""
    white = rng.standard_normal(n + 2000)
    wn = min(cutoff_hz * 2.0 * dt, 0.99)
    y = sosfilt(butter(2, wn, output="sos"), white)[2000:]
    return y / np.std(y)


def steps(t: np.ndarray, t_start: float, axis: int, level: float, hold: float = 2.0,
          gap: float = 2.0) -> np.ndarray:
    """Stick steps on each axis in turn: ``level`` for ``hold`` s, then 0 for ``gap`` s.

    Returns
    -------
    ndarray
        (n, 3) excitation with the steps of roll, pitch, yaw (axis order) starting at
        ``t_start + axis * (hold + gap)``; ``axis`` = −1 steps all three axes in turn.
    """
    out = np.zeros((t.size, 3))
    axes = range(3) if axis < 0 else [axis]
    for j, ax in enumerate(axes):
        t0 = t_start + j * (hold + gap)
        out[(t >= t0) & (t < t0 + hold), ax] = level
    return out


def taper_window(t: np.ndarray, t_start: float, t_end: float, ramp: float = 1.0) -> np.ndarray:
    """1 between ``t_start + ramp`` and ``t_end - ramp``, cosine ramps, 0 outside."""
    up = np.clip((t - t_start) / ramp, 0.0, 1.0)
    down = np.clip((t_end - t) / ramp, 0.0, 1.0)
    return (0.5 - 0.5 * np.cos(np.pi * up)) * (0.5 - 0.5 * np.cos(np.pi * down))


def stick_excitation(
    t: np.ndarray, rng: np.random.Generator, kind: str, amplitude: tuple[float, float, float],
    f_min: float = 0.1, f_max: float = 8.0, t_start: float = 2.0, t_end: float | None = None,
) -> np.ndarray:
    """Roll/pitch/yaw stick excitation of one flight.

    Parameters
    ----------
    t : ndarray
        Time of every control step, s (uniform).
    rng : numpy.random.Generator
        Seeded generator (random parts: noise, comb phases do not use it).
    kind : str
        One of ``EXCITATIONS``. ``mixed`` sums an axis-interleaved multisine, filtered noise
        and one chirp per axis in its own third of the flight; ``steps`` puts held steps of
        size ``amplitude`` on roll, pitch and yaw in turn.
    amplitude : tuple of float
        Peak stick deflection per axis (roll, pitch, yaw), 0..1.
    f_min, f_max : float
        Band of the excitation, Hz.
    t_start, t_end : float
        Quiet time before (and the end of) the excitation, s.

    Returns
    -------
    ndarray
        (n, 3) stick excitation.
    """
    n = t.size
    amp = np.asarray(amplitude, dtype=float)
    out = np.zeros((n, 3))
    if kind == "none" or n == 0:
        return out
    dt = float(t[1] - t[0]) if n > 1 else 1.0
    t_end = float(t[-1]) if t_end is None else t_end
    if kind == "steps":
        return steps(t, t_start, -1, 1.0) * amp
    win = taper_window(t, t_start, t_end)
    df = 1.0 / MULTISINE_PERIOD
    k_all = np.arange(max(1, int(np.ceil(f_min / df))), int(np.floor(f_max / df)) + 1)
    span = max(t_end - t_start, 1e-9)
    for ax in range(3):
        parts = []
        if kind in ("mixed", "multisine"):
            k = k_all[k_all % 3 == ax]
            f = k * df
            parts.append((0.5 if kind == "mixed" else 1.0,
                          multisine(t, f, 1.0 / (1.0 + f / 1.0))))
        if kind in ("mixed", "noise"):
            cut = 0.5 * (f_min + f_max) / 2.0
            noise = filtered_noise(n, dt, cut, rng) / 3.0
            parts.append((0.35 if kind == "mixed" else 1.0, noise))
        if kind == "mixed":
            t0 = t_start + ax * span / 3.0
            parts.append((0.5, chirp(t, f_min, f_max, t0, t0 + span / 3.0)))
        if kind == "chirp":
            parts.append((1.0, chirp(t, f_min, f_max, t_start, t_end)))
        s = sum(w * p for w, p in parts)
        peak = np.quantile(np.abs(s[win > 0.5]), 0.995) if np.any(win > 0.5) else 1.0
        out[:, ax] = np.clip(s / max(peak, 1e-12), -1.0, 1.0) * win * amp[ax]
    return out
