"""SIM's noise model: its roll/pitch laws refitted on whitened prediction errors.

Where SIM's rate loop mostly answers noise its log does not hold (:mod:`etsid.gap.loop`),
the least-squares command law is biased. Here the roll and pitch laws are refitted on SIM
with a noise model: each channel's residual is whitened by an autoregressive filter fitted
to it (generalised least squares, iterated), and SIM's command delay and motor lag are
searched on that whitened error. The direct prediction-error method is consistent in a
closed loop when its noise model is right (Ljung, *System Identification*, 2nd ed., 1999,
ch. 13); an autoregressive filter of order :data:`AR_ORDER` at the log's rate is that
model here. :mod:`etsid.gap.pem` scores REAL's roll and pitch
with it.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from etsid.gap.nominal import Mods, NominalModel, features
from etsid.gap.signals import Flight, derivative, lowpass

AR_ORDER = 6
"""Order of each channel's whitening filter (samples at the log's rate)."""
CUTOFF_HZ = 20.0
"""Low-pass of both the measured and the predicted angular accelerations, Hz: above the
8 Hz band, where a loop's answer to its noise lives, below the derivative's noise."""
GLS_ITERATIONS = 3
"""Whitening filter and law coefficients refitted in turn this many times."""
SIM_DELAYS_S = (0.0, 0.005, 0.01)
SIM_TAUS_S = (0.004, 0.007, 0.012)
"""SIM's command delay and motor lag searched on the whitened error, s."""
CHANNELS = ("p", "q")
"""Roll and pitch (yaw keeps its filtered residual: :data:`etsid.gap.pem.LOOP_CHANNELS`)."""


@dataclass
class WhitenedModel:
    """SIM's roll/pitch laws refitted on whitened errors, with each channel's noise model."""

    nominal: NominalModel
    """The nominal model with the refitted roll/pitch coefficients, delay and lag."""
    filters: dict[str, np.ndarray]
    """Channel → whitening filter (``[1, -a_1, …, -a_p]``)."""
    innovation: dict[str, float]
    """Channel → SIM's whitened mean square error, (rad/s²)²."""


def ar_filter(e: np.ndarray) -> np.ndarray:
    """Least-squares autoregressive whitening filter of ``e``."""
    p = AR_ORDER
    x = np.column_stack([e[p - k - 1:e.size - k - 1] for k in range(p)])
    a, *_ = np.linalg.lstsq(x, e[p:], rcond=None)
    return np.concatenate([[1.0], -a])


def whiten(filt: np.ndarray, x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``x`` (n,) or (n, k) through ``filt``, kept over ``mask``."""
    return lfilter(filt, [1.0], x, axis=0)[mask]


def measured_rates(flight: Flight, channels: tuple[str, ...] = CHANNELS
                   ) -> dict[str, np.ndarray]:
    acc = derivative(lowpass(flight.rates, flight.fs, CUTOFF_HZ), flight.fs)
    return {c: acc[:, j] for j, c in enumerate(("p", "q", "r")) if c in channels}


def fit_whitened(sim: Flight, nominal: NominalModel, taus: tuple[float, ...] = SIM_TAUS_S,
                 channels: tuple[str, ...] = CHANNELS) -> WhitenedModel:
    """SIM's laws of ``channels`` (default roll and pitch) by generalised least squares on
    its airborne samples, for each command delay and motor lag of :data:`SIM_DELAYS_S` ×
    ``taus`` (s); the pair with the smallest whitened error is kept."""
    y = measured_rates(sim, channels)
    mask = sim.airborne
    best: tuple[float, float, float, dict] | None = None
    for delay in SIM_DELAYS_S:
        for tau in taus:
            feats = features(sim, nominal.k, tau, Mods(), channels, delay, nominal.v_ref)
            fits = {}
            for c in channels:
                x = lowpass(feats[c], sim.fs, CUTOFF_HZ)
                filt = np.array([1.0])
                for _ in range(GLS_ITERATIONS):
                    coef, *_ = np.linalg.lstsq(whiten(filt, x, mask), whiten(filt, y[c], mask),
                                               rcond=None)
                    filt = ar_filter((y[c] - x @ coef)[mask])
                w = whiten(filt, y[c] - x @ coef, mask)[AR_ORDER:]
                fits[c] = (coef, filt, float(np.var(w)))
            total = sum(v[2] for v in fits.values())
            if best is None or total < best[0]:
                best = (total, delay, tau, fits)
    assert best is not None
    _, delay, tau, fits = best
    model = copy.copy(nominal)
    model.coef = {**nominal.coef, **{c: fits[c][0] for c in channels}}
    model.delay, model.tau = delay, tau
    return WhitenedModel(model, {c: fits[c][1] for c in channels},
                         {c: fits[c][2] for c in channels})
