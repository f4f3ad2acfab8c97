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

REAL's own sensor noise is the lower bound of each channel's innovation scale: the floor
of :func:`etsid.gap.floors.channel_floors` (the larger of SIM's held-out error and REAL's
sensor noise) divided by SIM's residual RMS scales SIM's innovation deviation up where
REAL is the noisier log.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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
        Innovation deviation floor, in the channel's unit: SIM's innovation deviation,
        raised by REAL's sensor noise where that is larger.
    step : int
        Decimation: the channel is read every ``step`` samples (at absolute indices that
        are multiples of it).
    """

    coef: np.ndarray
    sigma: float
    step: int = 1

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


def fit_noise(sim_residuals: dict[str, np.ndarray], sim_mask: np.ndarray,
              floors: dict[str, float], fs: float, cutoffs: dict[str, float]) -> NoiseModel:
    """The noise model from SIM's residuals under its own nominal model.

    Parameters
    ----------
    sim_residuals : dict
        Channel → SIM's measured minus nominal prediction (full length).
    sim_mask : ndarray of bool
        SIM's airborne samples.
    floors : dict
        Channel → floor (unit of the channel): the larger of SIM's held-out error and
        REAL's sensor noise.
    fs : float
        Sample rate of the analysis grid, Hz.
    cutoffs : dict
        Channel → low-pass cut-off of its residual, Hz.
    """
    out = {}
    for c, e in sim_residuals.items():
        if c not in floors:
            continue
        ok = sim_mask & np.isfinite(e)
        step = decimation(fs, cutoffs[c])
        coef, sd = fit_ar(np.nan_to_num(e), ok, step)
        rms = float(np.sqrt(np.mean(e[ok] ** 2))) if np.any(ok) else 0.0
        scale = max(floors[c] / rms, 1.0) if rms > 0 else 1.0
        out[c] = ChannelNoise(coef, max(sd * scale, 1e-12), step)
    return NoiseModel(out)
