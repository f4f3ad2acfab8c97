"""Whether SIM's rate loop mostly answers disturbances its log does not hold.

A closed rate loop that answers its own motor or air noise makes its commands follow that
noise. The nominal model's command → angular-acceleration law, a least-squares fit, is then
right on average and wrong band by band: the measured response grows against the
prediction with frequency (toward the inverse of the controller). A change in the loop's
timing or inertia then shows as a changed noise response, not as its own law, and the
laws of :data:`LOOP_SENSITIVE` can hide or take each other's place (PyFlyt's Crazyflie,
whose motors add 2 % of the throttle as noise at every physics step: flown without that
noise, the same analysis names its delays, lags and rate dampings). Read on SIM, where no
hidden effect can be the cause.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.signal import csd, welch

from etsid.gap.nominal import LABELS, RATE_CHANNELS, NominalModel
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
disturbances (rule in docs/gap.md, "Loops that answer their own noise")."""
LOOP_SENSITIVE = ("inertia_scale", "time_delay", "motor_lag", "rate_damping",
                  "rotor_inertia", "yaw_torque_scale")
"""Laws whose only evidence is how the rates answer the commands (the loop's timing, its
inertia or its authority in yaw): the ones such a loop hides or confuses."""
LOOP_CONFIDENCE = 0.5
"""Highest confidence of a :data:`LOOP_SENSITIVE` law named while SIM's loop answers noise."""


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


def loop_words(resp: BandResponse, sim_name: str) -> str:
    """Words for a noise-driven loop, with the channel's two band gains."""
    lo, hi = resp.gains[resp.channel] if resp.channel else (float("nan"),) * 2
    name = LABELS.get(resp.channel or "", "angular acceleration")
    return (f"{sim_name}'s rate loop answers noise its log does not hold ({name} {lo:.2f}× "
            f"its model at {_band(0)}, {hi:.2f}× at {_band(1)})")


def _band(i: int) -> str:
    lo, hi = LOOP_BANDS_HZ[i]
    return f"{lo:g}-{hi:g} Hz"


def either(names: list[str] | tuple[str, ...]) -> str:
    """Law names in words, "a, b or c"."""
    words = [n.replace("_", " ") for n in names]
    return ", ".join(words[:-1]) + " or " + words[-1] if len(words) > 1 else "".join(words)


def could_hide(resp: BandResponse | None, sim_name: str, named: list[str]
               ) -> dict[str, Any] | None:
    """gap.json's ``could_hide`` when SIM's loop answers noise and no law of
    :data:`LOOP_SENSITIVE` is named: those laws and why they could hide."""
    if resp is None or not resp.noise_driven or set(named) & set(LOOP_SENSITIVE):
        return None
    return {"laws": list(LOOP_SENSITIVE), "why": loop_words(resp, sim_name)}


def caveat_loop_laws(effects: list[dict[str, Any]], resp: BandResponse | None,
                     sim_name: str) -> None:
    """Caveat each named law of :data:`LOOP_SENSITIVE` when SIM's loop answers noise, at
    most :data:`LOOP_CONFIDENCE` (PyFlyt set 321: a 17 ms delay named an inertia scale at
    confidence 1.0)."""
    if resp is None or not resp.noise_driven:
        return
    for e in effects:
        if e["name"] in LOOP_SENSITIVE and "caveat" not in e:
            e["caveat"] = (f"{loop_words(resp, sim_name)}: a change of {either(LOOP_SENSITIVE)} "
                           "alters that answer and may pass for another of them")
            e["confidence"] = min(float(e["confidence"]), LOOP_CONFIDENCE)
