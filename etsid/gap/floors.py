"""Noise floors: how far a channel may differ before the difference means anything.

A channel's floor ``σ_c`` is the larger of two errors, each measured on one log alone:

* **SIM's own**: the nominal model fitted on SIM's first part and scored on its last part
  (noise and model error together; what "as good as on SIM" means);
* **REAL's sensor noise**: the white-noise level of REAL's gyro and accelerometer, read
  off their power spectrum above the analysis band (:data:`NOISE_BAND_HZ`, where the
  model predicts nothing), pushed through the channel's own processing (low-pass,
  derivative) by :func:`etsid.gap.nominal.measured` itself.

A noise-free simulation (a replayed twin) has a tiny own error; without the second term
every channel of a real recording would look mismatched by orders of magnitude.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import welch

from etsid.gap.nominal import NominalModel, measured
from etsid.gap.signals import ANTIALIAS_SHARE, Flight, true_runs

NOISE_BAND_HZ = 12.0
"""Lower edge of the band read for sensor noise, Hz (above the 8 Hz analysis band and
the airframe's rigid-body response); the upper edge is 90 % of the anti-alias cut-off."""
SEGMENT_S = 2.0
"""Welch segment length, s."""
GYRO_FLOOR = 0.009
"""rad/s: the flight-to-flight difference of a calibrated MEMS gyro's bias (≈0.3 °/s =
0.005 rad/s per flight, two flights compared: 0.007 rad/s) is not evidence of missing
physics; 0.009 adds a margin of about 30 %, and was checked against etsid's own
no-effect pairs (partly set on seen pairs, then)."""
KINEMATIC_FLOOR = 0.1
"""m/s²: the accelerometer is compared with the velocity through the estimated attitude; a
good estimator's tilt error of about 0.5° alone gives g·sin(0.5°) ≈ 0.09 m/s² in x and y,
and a calibrated MEMS accelerometer's offset differs by ≈ 3 mg between flights. (0.05 m/s²
was too low: a no-effect held-out pair with a Mahony estimator reached 2.0× it in x.)"""
_SYNTH_SAMPLES = 30000
_SYNTH_SEED = 20240521


def _band(fs: float) -> tuple[float, float] | None:
    hi = 0.9 * min(ANTIALIAS_SHARE * fs, 0.5 * fs)
    return (NOISE_BAND_HZ, hi) if hi > 1.3 * NOISE_BAND_HZ else None


def noise_density(x: np.ndarray, fs: float, mask: np.ndarray) -> float | None:
    """One-sided white-noise power density (unit²/Hz) of ``x`` over the airborne runs in
    ``mask``: the median of its Welch spectrum in the noise band. None when the log is too
    slow for the band or the runs are too short."""
    band = _band(fs)
    nper = int(SEGMENT_S * fs)
    if band is None or nper < 16:
        return None
    levels, weights = [], []
    for a, b in true_runs(mask):
        if b - a < nper:
            continue
        f, pxx = welch(x[a:b], fs=fs, nperseg=nper, detrend="linear")
        sel = (f >= band[0]) & (f <= band[1])
        if np.any(sel):
            levels.append(float(np.median(pxx[sel])))
            weights.append(b - a)
    if not levels:
        return None
    return float(np.average(levels, weights=weights))


def sensor_noise(flight: Flight) -> dict[str, np.ndarray]:
    """Channel → a series of REAL's own sensor noise alone after the channel's processing
    (white noise at the gyro's and accelerometer's measured densities pushed through
    :func:`etsid.gap.nominal.measured`; same units as the channel, its filter's start-up
    trimmed). Channels without a measurable noise level (a slow log, no long airborne run)
    are absent."""
    hit = flight.__dict__.get("_sensor_noise")
    if hit is not None and hit[0] is flight.rates:
        return hit[1]
    out = _sensor_noise(flight)
    flight.__dict__["_sensor_noise"] = (flight.rates, out)
    return out


def _sensor_noise(flight: Flight) -> dict[str, np.ndarray]:
    dens_rate = [noise_density(flight.rates[:, j], flight.fs, flight.airborne) for j in range(3)]
    dens_acc = [noise_density(flight.acc[:, j], flight.fs, flight.airborne)
                if np.all(np.isfinite(flight.acc[:, j])) else None for j in range(3)]
    if all(d is None for d in dens_rate + dens_acc):
        return {}
    n = min(flight.n, _SYNTH_SAMPLES)
    rng = np.random.default_rng(_SYNTH_SEED)

    def white(dens: list[float | None]) -> np.ndarray:
        std = np.array([np.sqrt(d * flight.fs / 2.0) if d is not None else 0.0 for d in dens])
        return rng.standard_normal((n, 3)) * std

    synth = Flight(name="noise", t=np.arange(n) / flight.fs, fs=flight.fs,
                   motors=np.zeros((n, 1)), inputs=flight.inputs, rates=white(dens_rate),
                   acc=white(dens_acc), att=np.zeros((n, 3)), v_body=np.zeros((n, 3)),
                   alt=np.zeros(n), vbat=np.zeros(n), airborne=np.ones(n, dtype=bool),
                   have={"vel", "roll"})
    out = {}
    for c, y in measured(synth).items():
        src = dens_rate if c in ("p", "q", "r") or c.startswith("gyro_") else dens_acc
        axis = {"p": 0, "q": 1, "r": 2, "gyro_p": 0, "gyro_q": 1, "gyro_r": 2, "ax": 0,
                "ay": 1, "az": 2, "kin_x": 0, "kin_y": 1, "kin_z": 2}.get(c)
        if axis is None or src[axis] is None:
            continue
        y = np.asarray(y[n // 10: -n // 10], dtype=float)
        # noise alone has no mean: the still synthetic flight's kinematics leave gravity
        # (9.81 m/s²) on kin_z, which would otherwise read as noise
        out[c] = y - np.mean(y)
    return out


def sensor_floors(flight: Flight) -> dict[str, float]:
    """Channel → the error REAL's own sensor noise alone gives after the channel's
    processing (the deviation of :func:`sensor_noise`'s series)."""
    return {c: float(np.std(y)) for c, y in sensor_noise(flight).items()}


def own_error(sim: Flight, nominal: NominalModel, probe: NominalModel, hold: np.ndarray,
              parts: list[np.ndarray]) -> dict[str, float]:
    """SIM's own error per channel: the larger of the ``probe`` model's (fitted on SIM's
    first part) RMSE on SIM's held-out ``hold``, and the full ``nominal`` model's RMSE on
    each of ``parts`` of SIM (the parts REAL's evidence will be read on: all of it and the
    split REAL is scored with).

    A floor is "as good as SIM's own model does on SIM", measured as REAL will be measured:
    SIM compared with itself by the verdict's own rules then never exceeds its floors,
    whatever stretch of the flight is busier than the held-out one (a real flight's gyro
    against its attitude varies by a factor of three along the flight, which a single
    held-out stretch does not see)."""
    ys = measured(sim)
    probe_pred = probe.predict(sim)
    full_pred = nominal.predict(sim)
    out: dict[str, float] = {}
    for c, y in ys.items():
        if c not in probe_pred:
            continue
        terms = [float(np.sqrt(np.mean((y - probe_pred[c])[hold] ** 2)))] if np.any(hold) \
            else []
        if c in full_pred:
            terms += [float(np.sqrt(np.mean((y - full_pred[c])[m] ** 2))) for m in parts
                      if np.any(m)]
        out[c] = max(terms) if terms else 0.0
    return out


def channel_floors(sim_error: dict[str, float], real: Flight) -> tuple[dict[str, float],
                                                                      dict[str, str]]:
    """Floor per channel: ``max(SIM's own held-out error, REAL's sensor noise, fixed
    floor)``, and for each channel which term set it (``"sim"``, ``"real noise"``,
    ``"bias floor"``)."""
    real_noise = sensor_floors(real)
    sigma: dict[str, float] = {}
    source: dict[str, str] = {}
    for c, s in sim_error.items():
        fixed = GYRO_FLOOR if c.startswith("gyro_") else (
            KINEMATIC_FLOOR if c.startswith("kin_") else 0.0)
        terms = {"sim": s, "real noise": real_noise.get(c, 0.0), "bias floor": fixed}
        key = max(terms, key=terms.get)
        sigma[c], source[c] = max(terms[key], 1e-12), key
    return sigma, source
