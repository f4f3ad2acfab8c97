"""Could one vehicle explain both logs? Said first, before any physics is named.

A fault or a missing effect changes a vehicle by a bounded amount: a thrust scale of
±20 %, a heavier inertia of 30–60 %, a sagging pack. Two *different* airframes differ by
more, and on several ratios at once. The checks compare what each log says about its own
vehicle, each measured on that log alone:

* the rotor count and the kind of inputs (structural; :func:`structural`);
* the hover thrust command, as ``mean((m + k)²)`` (thrust-to-weight), as logged and at equal
  pack voltage: the pack is a condition of the day, not of the airframe (an autopilot that
  compensates the voltage, as PX4's MC_BAT_SCALE_EN does, logs commands already
  normalised; one that does not needs ``(V_sim/V)²`` more), so only a ratio outside the
  range both ways is evidence;
* the pack voltage: reported, never judged (the coaxial octocopter flies a 4S and a 3S pack);
* the control effectiveness per axis: REAL's angular acceleration regressed on SIM's
  nominal prediction, each at the command-to-response delay (0–:data:`MAX_DELAY_S`) that
  fits it best, REAL's slope over SIM's: a late response then reads as a delay, not as a
  weaker airframe (a refit of REAL's own model at SIM's delay read a 20–40 ms shift as an
  8–13× roll effectiveness); both above :data:`EFFECTIVENESS_HIGHPASS_HZ`, where the loops'
  steady trim of a slow disturbance does not enter (a rotor drag's pitch moment, held by a
  steady pitch command that SIM's prediction reads as pitch acceleration, read 0.17×);
* the rate-response bandwidth: each log's own fitted motor time constant (reported, not
  judged: a slow motor is a fault the vocabulary names).

A ratio outside :data:`PLAUSIBLE` is evidence of a different airframe.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy.signal import butter, sosfiltfilt

from etsid.gap.nominal import Mods, NominalModel, fit_nominal, measured
from etsid.gap.signals import Flight

PLAUSIBLE = {
    "hover thrust": (1 / 1.6, 1.6),
    "hover thrust at equal voltage": (1 / 1.6, 1.6),
    "roll effectiveness": (0.2, 5.0),
    "pitch effectiveness": (0.2, 5.0),
}
"""REAL/SIM ratios one airframe with a fault can reach. Hover thrust: a 20 % thrust loss
(1.25×) plus a payload, not a vehicle that needs 1.6× the thrust command; judged as logged
and at equal voltage (``(m + k)² (V/V_sim)²``: an ESC's duty drives the motor at duty × V),
and evidence only when both are outside (whether the autopilot compensates the pack is not
in the log). The pack voltage itself is not judged: a pack is a consumable. Effectiveness
(each read at its best delay, :func:`_gains_at_best_delay`): a 60 % heavier inertia with a
20 % weaker thrust is 0.5×, and a lag three times SIM's moves it further, so only a factor
of five says another airframe. Yaw effectiveness is reported, not judged: the reaction
torque and the rotor spin-up torque share their regressors, and a changed rotor inertia
moves the split between them by several times on one airframe."""
AXES = (("roll effectiveness", "p"), ("pitch effectiveness", "q"), ("yaw effectiveness", "r"))


@dataclass
class VehicleCheck:
    """What the two logs say about their vehicles."""

    ratios: dict[str, float] = field(default_factory=dict)
    evidence: list[str] = field(default_factory=list)
    bandwidth: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        """gap.json ``vehicle_check``."""
        return {"ratios": self.ratios, "plausible": {k: list(v) for k, v in PLAUSIBLE.items()
                                                     if k in self.ratios},
                "evidence": self.evidence, "motor_time_constant_s": self.bandwidth}


def structural(sim: Flight, real: Flight) -> str | None:
    """A difference no fault makes: the number of rotors (or of commands)."""
    if sim.inputs == real.inputs and sim.motors.shape[1] != real.motors.shape[1]:
        return (f"{real.name} has {real.motors.shape[1]} motor outputs, {sim.name} "
                f"{sim.motors.shape[1]}: another rotor count is another airframe")
    return None


def _hover(flight: Flight, k: float) -> float:
    if flight.inputs == "motors":
        power = np.mean((np.clip(flight.motors, 0, 1) + k) ** 2, axis=1)
    else:
        power = (np.clip(flight.motors[:, 0], 0, 1) + k) ** 2
    return float(np.median(power[flight.airborne]))


def _effectiveness(model: NominalModel, channel: str, n_inputs: int) -> float:
    """RMS of the channel's coefficients on the differential thrust (p, q) or reaction
    torque (r) of each input: the first ``n_inputs`` regressors of the channel."""
    coef = model.coef.get(channel)
    if coef is None:
        return float("nan")
    return float(np.sqrt(np.mean(coef[:n_inputs] ** 2)))


MAX_DELAY_S = 0.15
"""Longest command-to-response delay tried when reading a log's effectiveness, s (well past
the vocabulary's 10–60 ms delays and a slow ESC's lag)."""
DELAY_STEP_S = 0.015
EFFECTIVENESS_HIGHPASS_HZ = 0.5
"""Hz: the effectiveness is read above this: the rate loops answer a command within tens of
milliseconds, while the trim that holds a slow disturbance (a drag moment growing with speed,
a CG offset, wind) changes over seconds."""


@lru_cache(maxsize=8)
def _highpass(fs: float) -> np.ndarray:
    return butter(2, EFFECTIVENESS_HIGHPASS_HZ / (0.5 * fs), "highpass", output="sos")


def _gains_at_best_delay(flight: Flight, nominal: NominalModel, channels: tuple[str, ...]
                         ) -> dict[str, float]:
    """Channel → slope of ``flight``'s measured channel on SIM's nominal prediction of it,
    at the delay in 0–:data:`MAX_DELAY_S` that fits that channel best (both high-passed at
    :data:`EFFECTIVENESS_HIGHPASS_HZ`, airborne samples)."""
    ys = measured(flight)
    chans = tuple(c for c in channels if c in ys and c in nominal.channels)
    m = flight.airborne
    best: dict[str, tuple[float, float]] = {}
    sos = _highpass(flight.fs)
    fast = {c: sosfiltfilt(sos, ys[c])[m] for c in chans}
    fast = {c: y - np.mean(y) for c, y in fast.items()}  # demeaned once, for every delay
    for d in np.arange(0.0, MAX_DELAY_S + 1e-9, DELAY_STEP_S):
        pred = nominal.predict(flight, Mods(delay=float(d)), chans)
        for c in chans:
            y = fast[c]
            x = sosfiltfilt(sos, pred[c])[m]
            x = x - np.mean(x)
            sxx = float(np.dot(x, x))
            if sxx <= 0:
                continue
            slope = float(np.dot(x, y)) / sxx
            sse = float(np.sum((y - slope * x) ** 2))
            if c not in best or sse < best[c][0]:
                best[c] = (sse, slope)
    return {c: v[1] for c, v in best.items()}


def check_vehicles(sim: Flight, real: Flight, nominal: NominalModel) -> VehicleCheck:
    """Ratios REAL/SIM of what defines an airframe, and the evidence among them."""
    out = VehicleCheck()
    k = nominal.k
    out.ratios["hover thrust"] = _hover(real, k) / max(_hover(sim, k), 1e-9)
    if "vbat" in sim.have and "vbat" in real.have:
        v_sim = float(np.nanmedian(sim.vbat[sim.airborne]))
        v_real = float(np.nanmedian(real.vbat[real.airborne]))
        out.ratios["pack voltage"] = v_real / max(v_sim, 1e-9)
        out.ratios["hover thrust at equal voltage"] = (out.ratios["hover thrust"]
                                                       * out.ratios["pack voltage"] ** 2)
    chans = tuple(c for _, c in AXES)
    g_real, g_sim = (_gains_at_best_delay(f, nominal, chans) for f in (real, sim))
    for name, c in AXES:
        a, b = g_real.get(c), g_sim.get(c)
        if a is not None and b is not None and b > 0:
            out.ratios[name] = a / b
    own = fit_nominal(real, law=(k, nominal.v_ref))
    out.bandwidth = {"sim": nominal.tau, "real": own.tau}
    thrust = [n for n in ("hover thrust", "hover thrust at equal voltage") if n in out.ratios]
    outside = {n: not PLAUSIBLE[n][0] < out.ratios[n] < PLAUSIBLE[n][1] for n in thrust}
    for name, ratio in out.ratios.items():
        if name not in PLAUSIBLE:
            continue
        if name in outside and not all(outside.values()):
            continue  # the pack explains it one way or the other: a condition, not evidence
        lo, hi = PLAUSIBLE[name]
        if not lo < ratio < hi:
            out.evidence.append(f"{name} {ratio:.2f}× {sim.name}'s (one airframe with a fault "
                                f"stays within {lo:.2f}–{hi:.2f}×)")
    return out
