"""Roll and pitch read by their one-step prediction errors (the likelihood criterion).

A multirotor's rate loop is closed: where it mostly answers noise its log does not hold
(a motor's per-step jitter), the logged command is correlated with the angular
acceleration's unexplained part, and a candidate fitted by the squared error of the
low-passed residual is biased. On PyFlyt's hover pairs a 12.5 ms command delay then fits
as 0 ms and an inertia ×0.66 explains the change better; with the simulator's motor noise
switched off the same fit finds 12.5 ms (docs/gap_results.md). The direct
prediction-error method is consistent in a closed loop when its noise model is right
(Ljung, *System Identification*, 2nd ed., 1999, ch. 13): here SIM's roll and pitch laws
are refitted by generalised least squares with an autoregressive noise model
(:func:`etsid.gap.whiten.fit_whitened`), and every model — the null and each candidate —
is scored and fitted on REAL's *innovations*: the residual of that law, whitened by SIM's
filter at the log's rate. Each channel's innovations are white under SIM's own noise, so
the criterion's Gaussian likelihood of them is a likelihood, not a sum over correlated
samples. Yaw, the forces and the sensor-consistency channels keep the nominal model and the
decimated noise model of :mod:`etsid.gap.noise`.

:mod:`etsid.gap.run` uses this scorer only where SIM's loop answers unlogged noise
(:attr:`etsid.gap.loop.BandResponse.noise_driven`): on a loop that follows its references
the direct fit is unbiased, and the whitened fit's lag and delay hide the timing laws
(docs/gap_results.md, round 4).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.signal import lfilter

from etsid.gap.fitting import Scorer
from etsid.gap.noise import ChannelNoise, NoiseModel
from etsid.gap.nominal import Mods
from etsid.gap.signals import Flight, lowpass_series
from etsid.gap.whiten import (
    CUTOFF_HZ,
    SIM_TAUS_S,
    WhitenedModel,
    fit_whitened,
    measured_rates,
)

LOOP_CHANNELS = ("p", "q")
"""Channels read as prediction errors. Yaw was tried the same way on PyFlyt's yaw pairs
(rotor inertia, yaw torque scale, no effect): no answer changed (docs/gap_results.md)."""


class PredictionErrorScorer(Scorer):
    """A :class:`~etsid.gap.fitting.Scorer` in which roll and pitch are whitened: measured
    and predicted angular accelerations (rad/s²) low-passed at 20 Hz and passed through
    SIM's whitening filter, so that their difference is the one-step prediction error of
    SIM's refitted laws (white under SIM's noise). The other channels are the base
    scorer's."""

    def __init__(self, base: Scorer, model: WhitenedModel) -> None:
        rates = measured_rates(base.ctx.flight, tuple(model.filters))
        white = {c: lfilter(model.filters[c], [1.0], rates[c]) for c in model.filters
                 if c in rates and c in base.measured}
        sigma = {**base.sigma, **{c: float(np.sqrt(model.innovation[c])) for c in white}}
        super().__init__(base.ctx, {**base.measured, **white}, sigma)
        self.base = base
        self.model = model
        self.white = tuple(white)

    def prediction(self, mods: Mods | None = None,
                   channels: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
        """Prediction per channel; roll and pitch whitened (their measured series are)."""
        chans = self.ctx.nominal.channels if channels is None else channels
        loop = tuple(c for c in chans if c in self.white)
        rest = tuple(c for c in chans if c not in loop)
        out = super().prediction(mods, rest) if rest else {}
        if loop:
            mods = mods or Mods()
            if mods.tau is not None:  # a motor lag scales SIM's own, as these laws have it
                mods = replace(mods, tau=mods.tau * self.model.nominal.tau / self.ctx.nominal.tau)
            flight = self.ctx.flight
            raw = self.model.nominal.predict_unfiltered(flight, mods, loop)
            have = [c for c in loop if c in raw]
            if have:
                smooth = lowpass_series([raw[c] for c in have], flight.fs, CUTOFF_HZ)
                for c, pred in zip(have, smooth, strict=True):
                    if mods.offset.get(c):
                        pred = pred + mods.offset[c]
                    out[c] = lfilter(self.model.filters[c], [1.0], pred)
        return out


def prediction_error_scorer(sim: Flight, base: Scorer) -> PredictionErrorScorer:
    """The scorer of REAL (``base``'s flight) with SIM's roll/pitch laws refitted on its
    whitened errors."""
    nominal = base.ctx.nominal
    # SIM's own lag as the nominal fit found it besides the short lags of the grid: a
    # heavy airframe's motors are far slower than the grid's 12 ms
    taus = tuple(sorted({*SIM_TAUS_S, float(nominal.tau)}))
    chans = tuple(c for c in LOOP_CHANNELS if c in base.measured and c in nominal.channels)
    return PredictionErrorScorer(base, fit_whitened(sim, nominal, taus, chans))


def with_innovation_channels(noise: NoiseModel, scorer: PredictionErrorScorer) -> NoiseModel:
    """``noise`` with roll and pitch white (their residuals are already innovations) at
    SIM's innovation deviation."""
    own = {c: ChannelNoise(np.empty(0), scorer.sigma[c], 1) for c in scorer.white
           if c in noise.channels}
    return NoiseModel({**noise.channels, **own})
