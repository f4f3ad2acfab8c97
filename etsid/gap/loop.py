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
from scipy import stats
from scipy.signal import csd, welch

from etsid.gap.calibration import CALIBRATION_PATH, load_calibration
from etsid.gap.nominal import RATE_CHANNELS, NominalModel
from etsid.gap.signals import Flight

LOOP_BANDS_HZ = ((1.0, 4.0), (4.0, 8.0))
"""The two bands of the analysis band (Hz) whose response gains are compared."""
SEGMENT_S = 2.56
"""Welch segment length, s (0.39 Hz resolution: 7 bins in the low band)."""
MIN_SEGMENTS = 3
"""Least number of segments in SIM's longest airborne stretch."""
LOOP_TILT = 1.3
"""High-band gain over low-band gain from which SIM's loop counts as answering unrecorded
disturbances (the tilt's lower confidence bound at the stated rate must reach it), and roll
and pitch are scored as prediction errors: a loop that follows its references reads about
1 (etsid's simulator, the octocopter), PyFlyt's Crazyflie with its per-step motor noise
about 2; 1.3 sits between them (set on those generators)."""
@dataclass
class BandResponse:
    """SIM's measured-over-predicted angular-acceleration gains in :data:`LOOP_BANDS_HZ`."""

    gains: dict[str, tuple[float, float]]
    """Channel → (low-band gain, high-band gain), channels with both bands coherent beyond
    chance (:func:`coherence_limit`)."""
    tilt: float
    """High-over-low gain ratio of :attr:`channel` (NaN without one)."""
    channel: str | None
    """The channel whose tilt has the highest lower confidence bound."""
    tilt_low: float = float("nan")
    """That lower bound: the tilt over its log-normal error at the stated rate, shared by
    the channels (:func:`tilt_error`)."""

    @property
    def noise_driven(self) -> bool:
        """Whether SIM's loop answers disturbances its log does not hold: the tilt's lower
        confidence bound reaches :data:`LOOP_TILT`."""
        return bool(np.isfinite(self.tilt_low) and self.tilt_low >= LOOP_TILT)

    def as_dict(self) -> dict[str, object]:
        """gap.json form."""
        return {"bands_hz": [list(b) for b in LOOP_BANDS_HZ],
                "gains": {c: list(g) for c, g in self.gains.items()},
                "tilt": None if not np.isfinite(self.tilt) else self.tilt,
                "tilt_low": None if not np.isfinite(self.tilt_low) else self.tilt_low,
                "noise_driven": self.noise_driven}


def coherence_limit(n_averages: int, rate: float) -> float:
    """Band-summed magnitude-squared coherence that a measurement unrelated to the
    prediction exceeds with probability ``rate``, from ``n_averages`` independent spectral
    averages: ``1 − rate^(1/(n − 1))`` (with no coherence, P(γ̂² ≥ c) = (1 − c)^(n − 1));
    1 with fewer than two."""
    if n_averages < 2:
        return 1.0
    return float(1.0 - rate ** (1.0 / (n_averages - 1)))


def tilt_error(coherence: tuple[float, float], n_averages: tuple[int, int]) -> float:
    """Standard error of the log of a high-over-low gain ratio: each band's gain (cross over
    auto spectrum) has ``var(ln |H|) ≈ (1 − γ²) / (2 n γ²)`` for coherence γ² from n
    independent averages (Bendat and Piersol), the two bands independent."""
    return float(np.sqrt(sum(max(1.0 - g, 0.0) / (2.0 * n * g)
                             for g, n in zip(coherence, n_averages, strict=True))))


def _longest_run(mask: np.ndarray) -> slice:
    """The longest run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    starts, ends = edges[::2], edges[1::2]
    if not starts.size:
        return slice(0, 0)
    k = int(np.argmax(ends - starts))
    return slice(int(starts[k]), int(ends[k]))


def band_response(flight: Flight, nominal: NominalModel,
                  measured: dict[str, np.ndarray], rate: float | None = None) -> BandResponse:
    """Gains of ``flight``'s filtered angular accelerations (``measured``) over the nominal
    model's prediction, per band of :data:`LOOP_BANDS_HZ`, on its longest airborne stretch
    (cross-spectrum over auto-spectrum, band-summed; a band's bins times the stretch's
    non-overlapping segments count as its independent averages). A band gives a gain only
    where the prediction is coherent with the measurement beyond chance, and the loop is
    judged on the tilt's lower confidence bound, both at ``rate`` shared by the tests made
    (Bonferroni): default the package calibration's stated rate, so that SIM's loop is read
    alike whatever thresholds a run decides REAL with (a recording's loose ones included)."""
    if rate is None:
        rate = load_calibration(str(CALIBRATION_PATH)).false_positive_rate
    none = BandResponse({}, float("nan"), None)
    fs = flight.fs
    nper = int(2 ** np.round(np.log2(SEGMENT_S * fs)))
    run = _longest_run(flight.airborne)
    if fs < 2.5 * LOOP_BANDS_HZ[-1][1] or run.stop - run.start < MIN_SEGMENTS * nper:
        return none
    chans = tuple(c for c in RATE_CHANNELS if c in nominal.channels and c in measured)
    pred = nominal.predict(flight, None, chans)
    gains: dict[str, tuple[float, float]] = {}
    low: dict[str, float] = {}
    n_segments = (run.stop - run.start) // nper
    z = float(stats.norm.ppf(1.0 - rate / max(len(chans), 1)))
    for c in chans:
        x, y = pred[c][run], measured[c][run]
        f, pxy = csd(x, y, fs=fs, nperseg=nper)
        _, pxx = welch(x, fs=fs, nperseg=nper)
        _, pyy = welch(y, fs=fs, nperseg=nper)
        band, coh, n_avg = [], [], []
        for lo, hi in LOOP_BANDS_HZ:
            k = (f >= lo) & (f < hi)
            sxy, sxx, syy = np.sum(pxy[k]), float(np.sum(pxx[k])), float(np.sum(pyy[k]))
            n = n_segments * int(k.sum())
            g2 = abs(sxy) ** 2 / (sxx * syy) if sxx > 0 and syy > 0 else 0.0
            if g2 < coherence_limit(n, rate / (len(chans) * len(LOOP_BANDS_HZ))):
                break
            band.append(float(abs(sxy) / sxx))
            coh.append(float(g2))
            n_avg.append(n)
        if len(band) == len(LOOP_BANDS_HZ):
            gains[c] = (band[0], band[1])
            err = tilt_error((coh[0], coh[1]), (n_avg[0], n_avg[1]))
            low[c] = float(band[1] / band[0] * np.exp(-z * err))
    if not gains:
        return none
    top = max(low, key=low.__getitem__)
    return BandResponse(gains, gains[top][1] / gains[top][0], top, low[top])
