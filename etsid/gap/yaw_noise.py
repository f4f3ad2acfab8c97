"""Whether REAL's yaw loop has less of its motors' noise to answer than SIM's.

Over a rate loop that answers noise entering before the motors' lag (:mod:`etsid.gap.loop`),
much of the yaw command is the loop's answer to the yaw torque of the motors' speed
fluctuations. A rotor's spin-up reaction torque opposes the drag-torque kick of such a
fluctuation while the motor settles, so with more rotor inertia the noise's yaw torque
partly cancels and the yaw loop commands less: REAL's yaw command power falls across the
loop's band against SIM's, for flights of the same kind. The 8 Hz fit cannot see it (the
spin-up law is fitted to the logged commands, which the noise is not in). This reads that
fall; it names nothing by itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.signal import welch

from etsid.gap.candidates import LIBRARY
from etsid.gap.nominal import Mods, NominalModel
from etsid.gap.signals import Flight, lowpass
from etsid.gap.whiten import CUTOFF_HZ, SPECTRUM_SEGMENT

YAW_BANDS_HZ = ((0.25, 2.0), (2.0, 4.0), (4.0, 8.0), (8.0, 14.0))
"""Bands whose REAL-over-SIM yaw command power ratios are averaged (geometric mean), Hz:
from the flight's manoeuvres up to the loop's crossover."""
QUIET_YAW = 0.42
"""Yaw command power ratio at or below which, on REAL's fit part and its held-out part,
REAL's yaw loop answers less noise than SIM's: the smallest ratio both parts reached on the
84 seen no-effect PyFlyt pairs (0.63) over 1.5 (docs/gap.md, step 16)."""
QUIET_YAW_POOLED = 0.38
"""Or: the geometric mean of both parts' ratios at or below this, both parts below 1: the
smallest geometric mean of the same 84 pairs (0.57) over 1.5 (step 19)."""
ROTOR_INERTIA_ADDED = next(c for c in LIBRARY
                           if c.name == "rotor_inertia" and c.params[0].name == "added")
"""The rotor-inertia law this reading names: a spin-up torque SIM lacks or has less of."""


def yaw_command_power(nominal: NominalModel, flight: Flight, mask: np.ndarray) -> np.ndarray:
    """Power of the yaw angular acceleration ``flight``'s commands ask for (the model's
    prediction, low-passed at 20 Hz, its mean over ``mask`` taken out) in each band of
    :data:`YAW_BANDS_HZ`, (rad/s²)²/Hz (Welch over the ``mask`` samples)."""
    pred = lowpass(nominal.predict_unfiltered(flight, Mods(), ("r",))["r"], flight.fs,
                   CUTOFF_HZ)
    x = pred[mask] - np.mean(pred[mask])
    freq, power = welch(x, flight.fs, nperseg=min(SPECTRUM_SEGMENT, x.size))
    return np.array([np.mean(power[(freq >= lo) & (freq < hi)]) for lo, hi in YAW_BANDS_HZ])


@dataclass
class YawReading:
    """REAL's yaw command power over SIM's (geometric mean of the bands) on REAL's fit and
    held-out parts."""

    fit: float
    hold: float

    @property
    def pooled(self) -> float:
        """Geometric mean of both parts' ratios."""
        return float(np.sqrt(self.fit * self.hold))

    @property
    def quiet(self) -> bool:
        """Both parts at or below :data:`QUIET_YAW`, or below 1 with their geometric mean at
        or below :data:`QUIET_YAW_POOLED`."""
        top = max(self.fit, self.hold)
        return top <= QUIET_YAW or (top < 1.0 and self.pooled <= QUIET_YAW_POOLED)

    def as_dict(self) -> dict[str, Any]:
        """gap.json's ``yaw_command_power``."""
        return {"ratio_fit": self.fit, "ratio_held_out": self.hold, "ratio_pooled": self.pooled,
                "quiet": self.quiet}


def yaw_reading(nominal: NominalModel, sim: Flight, real: Flight, fit: np.ndarray,
                hold: np.ndarray) -> YawReading:
    """REAL's yaw command power over SIM's (all of SIM's airborne samples) on each part."""
    base = yaw_command_power(nominal, sim, sim.airborne)

    def ratio(mask: np.ndarray) -> float:
        return float(np.exp(np.mean(np.log(yaw_command_power(nominal, real, mask) / base))))

    return YawReading(ratio(fit), ratio(hold))


def quiet_yaw_evidence(reading: YawReading, sim_name: str, real_name: str) -> str:
    """The evidence sentence of the rotor inertia the reading names."""
    sig = ROTOR_INERTIA_ADDED.signature
    return (f"{sig[0].upper()}{sig[1:]}; {sim_name}'s loop answers noise its log does not "
            f"hold, and {real_name}'s yaw loop commands {reading.hold:.2f}× {sim_name}'s power "
            f"at {YAW_BANDS_HZ[0][0]:g}-{YAW_BANDS_HZ[-1][1]:g} Hz on its held-out part "
            f"({reading.fit:.2f}× on its fit part; {QUIET_YAW:g} or less on both, or "
            f"{QUIET_YAW_POOLED:g} or less as their geometric mean): a "
            "rotor's spin-up reaction opposes the yaw kick of its own speed fluctuations, so "
            "the yaw loop has less noise to answer; the coefficient is fitted to the logged "
            "commands on the fit part, which hold none of that noise")
