"""A rate-damping change read in the band a noise-driven loop leaves to its setpoints.

Where SIM's rate loop answers noise its log does not hold (:mod:`etsid.gap.loop`), a
linear rate damping ``ṗ −= d p`` hides twice: its share of REAL's prediction error is a
percent or two, and the rates it multiplies are partly the loop's own answer to that noise,
so a least-squares slope on them is biased. Below :data:`LOW_BAND_HZ` the rates follow the
flight's setpoints rather than the noise. Here each flight's whitened prediction error
(SIM's noise model, :mod:`etsid.gap.whiten`) is regressed on its own roll and pitch rates
low-passed at that band, SIM and REAL alike; what the closed loop adds to the slope is
common to both flights and cancels in their difference, which estimates REAL's extra
damping. It is a difference-in-differences read of one law: it names nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from etsid.gap.nominal import Mods
from etsid.gap.signals import Flight, lowpass
from etsid.gap.whiten import AR_ORDER, CHANNELS, CUTOFF_HZ, WhitenedModel, measured_rates, whiten

LOW_BAND_HZ = 4.0
"""Low-pass of the rate regressor, Hz: the top of the low band of :mod:`etsid.gap.loop`, in
which the loop's gain still follows the model."""


@dataclass
class DampingShift:
    """REAL's roll/pitch rate damping over SIM's, read in the low band."""

    value: float
    """Extra damping, 1/s (inverse-variance mean of roll and pitch)."""
    stderr: float
    """Its standard error, 1/s."""
    per_axis: dict[str, tuple[float, float]]
    """Channel → (extra damping, standard error), 1/s."""

    @property
    def z(self) -> float:
        """The shift in standard errors."""
        return self.value / self.stderr

    def as_dict(self) -> dict[str, Any]:
        """gap.json's ``low_band_damping``."""
        return {"extra_damping_per_s": self.value, "stderr_per_s": self.stderr,
                "per_axis": {c: {"extra_damping_per_s": v, "stderr_per_s": s}
                             for c, (v, s) in self.per_axis.items()}}


def damping_slopes(model: WhitenedModel, flight: Flight, mask: np.ndarray,
                   mods: Mods | None = None) -> dict[str, tuple[float, float]]:
    """Channel → (slope, standard error) of ``flight``'s whitened roll/pitch prediction
    error (under ``mods``) on its whitened low-band rate over ``mask``, rad/s² per rad/s
    (minus a damping)."""
    y = measured_rates(flight)
    raw = model.nominal.predict_unfiltered(flight, mods or Mods(), CHANNELS)
    out = {}
    for j, c in enumerate(CHANNELS):
        res = y[c] - lowpass(raw[c], flight.fs, CUTOFF_HZ)
        res = res - np.mean(res[mask])
        rate = lowpass(flight.rates[:, j], flight.fs, LOW_BAND_HZ)
        rate = rate - np.mean(rate[mask])
        w = whiten(model.filters[c], res, mask)[AR_ORDER:]
        x = whiten(model.filters[c], rate, mask)[AR_ORDER:]
        sxx = float(x @ x)
        slope = float(x @ w) / sxx
        out[c] = (slope, float(np.sqrt(np.var(w - slope * x) / sxx)))
    return out


def damping_shift(model: WhitenedModel, sim_slopes: dict[str, tuple[float, float]],
                  real: Flight, mask: np.ndarray, mods: Mods | None = None) -> DampingShift:
    """REAL's extra rate damping over SIM's: the difference of REAL's low-band slopes (over
    ``mask``, under ``mods``) and SIM's (:func:`damping_slopes` over its airborne samples),
    roll and pitch pooled."""
    s = sim_slopes
    r = damping_slopes(model, real, mask, mods)
    per_axis = {c: (-(r[c][0] - s[c][0]), float(np.hypot(r[c][1], s[c][1])))
                for c in CHANNELS}
    weights = {c: 1.0 / se ** 2 for c, (_, se) in per_axis.items()}
    total = sum(weights.values())
    value = sum(weights[c] * per_axis[c][0] for c in CHANNELS) / total
    return DampingShift(float(value), float(1.0 / np.sqrt(total)), per_axis)


Z_LOW_BAND = 3.9
"""Least |z| of the shift on both REAL's fit part and its held-out part, same sign, for the
low band to count: 1.5× the largest |z| both parts reached together on the 84 seen no-effect
PyFlyt pairs (2.6; docs/gap.md, step 15)."""
Z_POOLED = {1: 5.94, -1: 6.83}
"""Or: least z of both parts pooled (inverse-variance mean of the two shifts), both parts on
that side, per side: 1.5× the largest pooled z on that side of the same 84 no-effect pairs
(+3.96, −4.56; step 19). Two parts at 3.1 and 7.3 SE are as strong evidence as two at 5,
and the held-out part still has to agree in sign."""


@dataclass
class LowBandReading:
    """The damping shift on REAL's fit part and on its held-out part."""

    fit: DampingShift
    hold: DampingShift

    @property
    def pooled_z(self) -> float:
        """Both parts' shifts pooled (inverse-variance mean), in standard errors."""
        w_fit, w_hold = self.fit.stderr ** -2, self.hold.stderr ** -2
        return float((w_fit * self.fit.value + w_hold * self.hold.value)
                     / np.sqrt(w_fit + w_hold))

    @property
    def sign(self) -> int:
        """+1 (REAL damps more: a rate damping), -1 (REAL's loop answers more noise in the low
        band: a slower motor or a later command), 0 (within :data:`Z_LOW_BAND` on both parts
        and :data:`Z_POOLED` pooled)."""
        for sign in (1, -1):
            both = min(sign * self.fit.z, sign * self.hold.z)
            if both >= Z_LOW_BAND or (both > 0.0 and sign * self.pooled_z >= Z_POOLED[sign]):
                return sign
        return 0

    def as_dict(self) -> dict[str, Any]:
        """gap.json's ``low_band``."""
        return {"fit": self.fit.as_dict(), "held_out": self.hold.as_dict(),
                "z_fit": self.fit.z, "z_held_out": self.hold.z, "z_pooled": self.pooled_z,
                "sign": self.sign}


def low_band_reading(model: WhitenedModel, sim: Flight, real: Flight, fit: np.ndarray,
                     hold: np.ndarray, mods: Mods | None = None) -> LowBandReading:
    """:func:`damping_shift` on REAL's ``fit`` and ``hold`` parts."""
    sim_slopes = damping_slopes(model, sim, sim.airborne)
    return LowBandReading(damping_shift(model, sim_slopes, real, fit, mods),
                          damping_shift(model, sim_slopes, real, hold, mods))
