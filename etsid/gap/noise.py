"""The noise model of ``etsid gap``: one autoregressive whitening filter per channel.

SIM's residuals (what the nominal model fitted on SIM leaves of SIM itself: sensor noise
and the model's own error) are low-passed and autocorrelated, so their samples are not
independent evidence. Each channel's residual is modelled as an AR(p) process

    e_t = a_1 e_{t-1} + … + a_p e_{t-p} + ε_t,   ε_t ~ N(0, σ_ε²),

fitted by least squares on SIM's airborne samples, its order chosen by BIC. Filtering a
residual series with ``A(z) = 1 − Σ a_i z^-i`` gives innovations that are (nearly) white
under SIM's own noise; a likelihood of innovations weighs every frequency by the inverse
of SIM's residual power there (the Whittle view), so a slow offset is judged against
SIM's slow errors and a fast wobble against its fast ones.

Each channel's innovation floor is the largest of three deviations, all innovations of
the same filter: SIM's (scaled up by SIM's held-out error over its in-sample residual where
the nominal model does worse on data it was not fitted on), REAL's own sensor noise (white
noise at REAL's measured gyro and accelerometer densities, :func:`etsid.gap.floors.
sensor_noise`, through the channel's processing and the filter) and, on the
sensor-consistency channels only, REAL's own within-flight innovation deviation (below).

**Sensor-consistency channels** (gyro vs attitude, accelerometer vs velocity) compare two
sensors of one log through that log's attitude estimator. Every effect of the vocabulary
acts on them as a constant offset (a gyro or accelerometer bias and the lean it leaves);
their variation within a flight is the estimator's answer to what was flown, which no
effect changes and SIM's one flight cannot show. So their floor includes REAL's own
within-flight deviation (about REAL's mean), and their residual is modelled as

    e_t = β + u_t,   β ~ N(0, τ²) once per flight,   u_t the AR process above,

where β is the flight's offset (a sensor's turn-on bias, the estimator's settled lean).
A no-effect REAL is another flight of SIM's vehicle, so τ² is estimated from SIM's own
flight: the mean square of SIM's offsets over the sensor's three axes (k = 3 draws). In
innovations β appears as ``(1 − Σ a_i) β``; the floor of a model's innovation variance on
these channels is ``σ² + (1 − Σ a_i)² τ²`` (an offset within the between-flight spread is no
evidence), and REAL's offset is tested against τ by its F(1, k) distribution
(:func:`offset_z2`). The criterion's null on these channels is the same law: a model's gain
there is at most ``½ z²`` per flight (:mod:`etsid.gap.criterion`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from etsid.gap.nominal import GYRO_CHANNELS, KIN_CHANNELS, SENSOR_CHANNELS
from etsid.gap.signals import true_runs

MAX_ORDER = 12
"""Highest AR order tried (BIC picks the order): on the decimated grid below, 12 lags span
three periods of the channel's cut-off, longer than its low-pass filter's memory."""
SAMPLES_PER_CUTOFF = 4.0
"""Each channel is read every ``fs / (4 f_c)`` samples (f_c its low-pass cut-off): the
residuals carry nothing above f_c, and a grid at twice the Nyquist rate of that band keeps
what they carry while the AR filter never has to whiten the filter's empty stop band
(where it would amplify round-off by orders of magnitude)."""


def decimation(fs: float, cutoff: float) -> int:
    """Samples between the points a channel is read at (≥ 1)."""
    return max(int(fs / (SAMPLES_PER_CUTOFF * cutoff)), 1)


@dataclass(frozen=True)
class ChannelNoise:
    """One channel's whitening filter and innovation floor.

    Attributes
    ----------
    coef : ndarray
        AR coefficients ``a_1 … a_p`` on the decimated grid (empty: white).
    sigma : float
        Innovation deviation floor, in the channel's unit: the largest of SIM's innovation
        deviation, REAL's sensor noise's and (sensor-consistency channels) REAL's own
        within-flight innovation deviation.
    step : int
        Decimation: the channel is read every ``step`` samples (at absolute indices that
        are multiples of it).
    offset_sd : float
        τ, the between-flight spread of the channel's constant offset, in its unit (0 on
        the dynamic channels, which SIM's model fits with their offsets).
    offset_dof : int
        Draws τ was estimated from (0: not estimated).
    """

    coef: np.ndarray
    sigma: float
    step: int = 1
    offset_sd: float = 0.0
    offset_dof: int = 0

    @property
    def dc_gain(self) -> float:
        """``1 − Σ a_i``: the filter's gain at zero frequency (what a constant becomes)."""
        return float(1.0 - np.sum(self.coef))

    @property
    def floor_var(self) -> float:
        """Least innovation variance a model can claim on this channel: ``σ² + (1 − Σ a)²
        τ²``."""
        return self.sigma ** 2 + (self.dc_gain * self.offset_sd) ** 2

    @property
    def order(self) -> int:
        """AR order p."""
        return int(self.coef.size)

    def whiten(self, e: np.ndarray) -> np.ndarray:
        """Innovations ``A(z) e`` on the decimated grid, NaN at every other sample and where
        the filter has no history."""
        d, p = self.step, self.order
        out = np.full(e.size, np.nan)
        idx = np.arange(p * d, e.size, d)
        val = np.array(e[idx], dtype=float)
        for i in range(1, p + 1):
            val -= self.coef[i - 1] * e[idx - i * d]
        out[idx] = val
        return out


def _lagged(e: np.ndarray, mask: np.ndarray, p: int, step: int
            ) -> tuple[np.ndarray, np.ndarray]:
    """Regressors (lags 1..p on the grid of ``step``) and targets over the runs of
    ``mask``."""
    xs, ys = [], []
    for a, b in true_runs(mask):
        first = -(-(a + p * step) // step) * step
        idx = np.arange(first, b, step)
        if idx.size <= 1:
            continue
        ys.append(e[idx])
        xs.append(np.column_stack([e[idx - i * step] for i in range(1, p + 1)])
                  if p else np.empty((idx.size, 0)))
    if not ys:
        return np.empty((0, p)), np.empty(0)
    return np.vstack(xs), np.concatenate(ys)


def fit_ar(e: np.ndarray, mask: np.ndarray, step: int = 1, max_order: int = MAX_ORDER
           ) -> tuple[np.ndarray, float]:
    """AR coefficients and innovation deviation of ``e`` over ``mask`` on the grid of
    ``step``, order by BIC.

    Every order is scored on the same targets (those with ``max_order`` lags inside a run),
    so the BIC values compare like with like; one QR factorisation serves every order.
    """
    x_all, y = _lagged(e, mask, max_order, step)
    if y.size < 10 * (max_order + 1):
        sd = float(np.std(e[mask])) if np.any(mask) else 0.0
        return np.empty(0), sd
    n = y.size
    q, r = np.linalg.qr(x_all)
    qty = q.T @ y
    yty = float(y @ y)
    best: tuple[float, np.ndarray, float] | None = None
    for p in range(0, max_order + 1):
        if p and abs(r[p - 1, p - 1]) < 1e-12 * abs(r[0, 0]):
            break
        coef = np.linalg.solve(np.triu(r[:p, :p]), qty[:p]) if p else np.empty(0)
        rss = max(yty - float(qty[:p] @ qty[:p]), 0.0)
        var = max(rss / n, 1e-300)
        bic = n * np.log(var) + p * np.log(n)
        if best is None or bic < best[0]:
            best = (bic, coef, float(np.sqrt(var)))
    assert best is not None
    return best[1], best[2]


@dataclass
class NoiseModel:
    """Channel → :class:`ChannelNoise` (SIM's whitening and REAL's lower bound)."""

    channels: dict[str, ChannelNoise]

    def innovations(self, residuals: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Channel → whitened residual series (NaN where the filter has no history)."""
        return {c: self.channels[c].whiten(r) for c, r in residuals.items()
                if c in self.channels}


SENSOR_GROUPS = (GYRO_CHANNELS, KIN_CHANNELS)
"""Channels whose offsets are draws of one sensor's between-flight spread τ."""


def _innovation_sd(noise: ChannelNoise, e: np.ndarray, mask: np.ndarray | None = None,
                   demean: bool = False) -> float:
    """Deviation of ``noise``'s innovations of ``e`` (over ``mask``; about their mean with
    ``demean``), 0 when there are fewer than two."""
    v = noise.whiten(e)
    ok = np.isfinite(v) if mask is None else np.isfinite(v) & mask
    if np.sum(ok) < 2:
        return 0.0
    x = v[ok] - (np.mean(v[ok]) if demean else 0.0)
    return float(np.sqrt(np.mean(x ** 2)))


def fit_noise(sim_residuals: dict[str, np.ndarray], sim_mask: np.ndarray,
              floors: dict[str, float], fs: float, cutoffs: dict[str, float],
              real_noise: dict[str, np.ndarray] | None = None,
              real_residuals: dict[str, np.ndarray] | None = None,
              real_mask: np.ndarray | None = None) -> NoiseModel:
    """The noise model from SIM's residuals under its own nominal model, floored by REAL.

    Parameters
    ----------
    sim_residuals : dict
        Channel → SIM's measured minus nominal prediction (full length).
    sim_mask : ndarray of bool
        SIM's airborne samples.
    floors : dict
        Channel → SIM's held-out error (unit of the channel), at least its in-sample
        residual: where larger, SIM's innovation deviation is scaled up by the ratio.
    fs : float
        Sample rate of the analysis grid, Hz.
    cutoffs : dict
        Channel → low-pass cut-off of its residual, Hz.
    real_noise : dict, optional
        Channel → REAL's sensor noise alone through the channel's processing
        (:func:`etsid.gap.floors.sensor_noise`).
    real_residuals, real_mask : optional
        REAL's residuals under the nominal model and its airborne samples: the
        sensor-consistency channels' within-flight deviation.
    """
    out: dict[str, ChannelNoise] = {}
    offsets: dict[str, float] = {}
    real_noise = real_noise or {}
    for c, e in sim_residuals.items():
        if c not in floors:
            continue
        sensor = c in SENSOR_CHANNELS
        ok = sim_mask & np.isfinite(e)
        step = decimation(fs, cutoffs[c])
        e0 = np.nan_to_num(e)
        if sensor and np.any(ok):
            offsets[c] = float(np.mean(e[ok]))
            e0 = e0 - offsets[c]
        coef, sd = fit_ar(e0, ok, step)
        if not sensor:
            rms = float(np.sqrt(np.mean(e[ok] ** 2))) if np.any(ok) else 0.0
            sd *= max(floors[c] / rms, 1.0) if rms > 0 else 1.0
        ch = ChannelNoise(coef, max(sd, 1e-12), step)
        terms = [ch.sigma]
        if c in real_noise:
            terms.append(_innovation_sd(ch, real_noise[c]))
        if sensor and real_residuals is not None and c in real_residuals:
            r = real_residuals[c]
            terms.append(_innovation_sd(ch, np.nan_to_num(r), (
                real_mask if real_mask is not None else np.ones(r.size, bool)) & np.isfinite(r),
                demean=True))
        out[c] = ChannelNoise(coef, max(terms), step)
    for group in SENSOR_GROUPS:
        have = [offsets[c] for c in group if c in offsets and c in out]
        if not have:
            continue
        tau = float(np.sqrt(np.mean(np.square(have))))
        for c in group:
            if c in out:
                ch = out[c]
                out[c] = ChannelNoise(ch.coef, ch.sigma, ch.step, tau, len(have))
    return NoiseModel(out)


def offset_z2(noise: ChannelNoise, innov: np.ndarray, mask: np.ndarray) -> float:
    """REAL's offset on a sensor-consistency channel against the between-flight spread:
    ``μ² / ((1 − Σ a)² τ² + s²/m)`` with μ the mean of the ``m`` innovations over ``mask``
    and ``s`` their deviation about it. Under no effect it is distributed as F(1, k), k the
    draws τ came from (as χ²₁ were τ known); NaN on a channel without τ."""
    if noise.offset_dof <= 0:
        return float("nan")
    ok = mask & np.isfinite(innov)
    m = int(np.sum(ok))
    if m < 2:
        return float("nan")
    mu = float(np.mean(innov[ok]))
    s2 = float(np.var(innov[ok], ddof=1))
    den = (noise.dc_gain * noise.offset_sd) ** 2 + s2 / m
    return mu * mu / den if den > 0 else float("inf")
