"""Whether SIM's rate loop mostly answers disturbances its log does not hold.

A closed rate loop that answers its own motor or air noise makes its commands follow that
noise. The nominal model's command → angular-acceleration law, a least-squares fit, is then
right on average and wrong band by band: the measured response grows against the
prediction with frequency (toward the inverse of the controller). A change in the loop's
timing or inertia then shows as a changed noise response, not as its own law, and the
laws read from the rates' answer to the commands (inertia, delay, motor lag, rate damping,
rotor inertia, yaw torque) can hide or take each other's place (PyFlyt's Crazyflie,
whose motors add 2 % of the throttle as noise at every physics step: flown without that
noise, the same analysis names its delays, lags and rate dampings). Read on SIM, where no
hidden effect can be the cause. Over such a loop the gap analysis scores roll and pitch as
prediction errors (:mod:`etsid.gap.pem`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import csd, welch

from etsid.gap.nominal import RATE_CHANNELS, NominalModel
from etsid.gap.signals import Flight

LOOP_BANDS_HZ = ((1.0, 4.0), (4.0, 8.0))
"""The two bands of the analysis band (Hz) whose response gains are compared."""
MIN_COHERENCE = 0.5
"""Least band-averaged coherence of prediction and measurement for a band's gain to count
(a band the commands barely excite gives a gain of noise)."""
SEGMENT_S = 2.56
"""Welch segment length, s (0.39 Hz resolution: 7 bins in the low band)."""
MIN_SEGMENTS = 3
"""Least number of segments in SIM's longest airborne stretch."""
LOOP_TILT = 1.3
"""High-band gain over low-band gain from which SIM's loop counts as answering unrecorded
disturbances, and roll and pitch are scored as prediction errors: a loop that follows its
references reads about 1 (etsid's simulator, the octocopter), PyFlyt's Crazyflie with its
per-step motor noise about 2; 1.3 sits between them (set on those generators)."""
@dataclass
class BandResponse:
    """SIM's measured-over-predicted angular-acceleration gains in :data:`LOOP_BANDS_HZ`."""

    gains: dict[str, tuple[float, float]]
    """Channel → (low-band gain, high-band gain), channels with both bands coherent."""
    tilt: float
    """Largest high-over-low gain ratio over :attr:`gains` (NaN without one)."""
    channel: str | None
    """The channel of :attr:`tilt`."""

    @property
    def noise_driven(self) -> bool:
        """Whether SIM's loop answers disturbances its log does not hold."""
        return bool(np.isfinite(self.tilt) and self.tilt >= LOOP_TILT)

    def as_dict(self) -> dict[str, object]:
        """gap.json form."""
        return {"bands_hz": [list(b) for b in LOOP_BANDS_HZ],
                "gains": {c: list(g) for c, g in self.gains.items()},
                "tilt": None if not np.isfinite(self.tilt) else self.tilt,
                "noise_driven": self.noise_driven}


def _longest_run(mask: np.ndarray) -> slice:
    """The longest run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    starts, ends = edges[::2], edges[1::2]
    if not starts.size:
        return slice(0, 0)
    k = int(np.argmax(ends - starts))
    return slice(int(starts[k]), int(ends[k]))


def band_response(flight: Flight, nominal: NominalModel,
                  measured: dict[str, np.ndarray]) -> BandResponse:
    """Gains of ``flight``'s filtered angular accelerations (``measured``) over the nominal
    model's prediction, per band of :data:`LOOP_BANDS_HZ`, on its longest airborne stretch
    (cross-spectrum over auto-spectrum, band-summed)."""
    none = BandResponse({}, float("nan"), None)
    fs = flight.fs
    nper = int(2 ** np.round(np.log2(SEGMENT_S * fs)))
    run = _longest_run(flight.airborne)
    if fs < 2.5 * LOOP_BANDS_HZ[-1][1] or run.stop - run.start < MIN_SEGMENTS * nper:
        return none
    chans = tuple(c for c in RATE_CHANNELS if c in nominal.channels and c in measured)
    pred = nominal.predict(flight, None, chans)
    gains: dict[str, tuple[float, float]] = {}
    for c in chans:
        x, y = pred[c][run], measured[c][run]
        f, pxy = csd(x, y, fs=fs, nperseg=nper)
        _, pxx = welch(x, fs=fs, nperseg=nper)
        _, pyy = welch(y, fs=fs, nperseg=nper)
        band = []
        for lo, hi in LOOP_BANDS_HZ:
            k = (f >= lo) & (f < hi)
            sxy, sxx, syy = np.sum(pxy[k]), float(np.sum(pxx[k])), float(np.sum(pyy[k]))
            if sxx <= 0 or syy <= 0 or abs(sxy) ** 2 / (sxx * syy) < MIN_COHERENCE:
                break
            band.append(float(abs(sxy) / sxx))
        if len(band) == len(LOOP_BANDS_HZ):
            gains[c] = (band[0], band[1])
    if not gains:
        return none
    top = max(gains, key=lambda c: gains[c][1] / gains[c][0])
    return BandResponse(gains, gains[top][1] / gains[top][0], top)
