"""RC and servo PWM (µs) ↔ normalised sticks and motors: the one conversion of etsid.

Every reader (:mod:`etsid.ingest`) turns PWM into FlightTable values with
:func:`pwm_to_stick` / :func:`pwm_to_motor`, and every log writer (:mod:`etsid.sim.writers`)
goes back with :func:`stick_to_pwm` / :func:`motor_to_pwm`. It lives here, beside
:mod:`etsid.table`, because both sides need it and ``sim`` must not import ``ingest``.

An RC range is ``(min, centre, max)`` in µs (default :data:`DEFAULT_RC_RANGE_US`, the
ArduPilot/PX4 1000/1500/2000 µs; readers take it from
:attr:`etsid.ingest.base.ReadOptions.rc_range_us`):

* ``u_roll``, ``u_pitch``, ``u_yaw``: (pwm − centre) / (½ (max − min)), −1…1;
* ``u_thrust`` and motors ``m1…m8``: (pwm − min) / (max − min), 0…1.

Reading clips to those intervals and returns how many samples it clipped (readers report
the count in ``repaired``). 0, 65535 (``UINT16_MAX``, MAVLink's "unused channel") and
non-finite or negative values mean "no value" and become NaN. Writing does not clip: a
stick of 1.2 is written as 2100 µs, so a log can carry out-of-range PWM on purpose.

>>> values, clipped = pwm_to_stick(np.array([1000, 1500, 2100, 0]), "u_roll")
>>> values.tolist()[:3], clipped
([-1.0, 0.0, 1.0], 1)
>>> float(stick_to_pwm(np.array([0.5]), "u_thrust")[0])
1500.0
"""

from __future__ import annotations

import numpy as np

DEFAULT_RC_MAP: dict[str, int] = {"u_roll": 1, "u_pitch": 2, "u_thrust": 3, "u_yaw": 4}
"""Stick → RC channel number (1-based), ArduPilot's AETR order."""
DEFAULT_RC_RANGE_US: tuple[float, float, float] = (1000.0, 1500.0, 2000.0)
"""PWM min, centre, max, µs."""
UNUSED = 65535
"""MAVLink's value for an RC channel that is not used (``UINT16_MAX``)."""

RcRange = tuple[float, float, float]


def is_centred(column: str) -> bool:
    """Whether ``column`` is a centred stick (−1…1) rather than a 0…1 throttle or motor."""
    return column in ("u_roll", "u_pitch", "u_yaw")


def _to_unit(pwm: np.ndarray, centred: bool, rc_range_us: RcRange) -> tuple[np.ndarray, int]:
    lo, centre, hi = rc_range_us
    raw = np.asarray(pwm)
    v = raw.astype(np.float64)
    v[~np.isfinite(v) | (v <= 0) | (v == UNUSED)] = np.nan
    if centred:
        v = (v - centre) / (0.5 * (hi - lo))
        bounds = (-1.0, 1.0)
    else:
        v = (v - lo) / (hi - lo)
        bounds = (0.0, 1.0)
    with np.errstate(invalid="ignore"):
        clipped = int(((v < bounds[0]) | (v > bounds[1])).sum())
    return np.clip(v, *bounds), clipped


def pwm_to_stick(pwm: np.ndarray, column: str, rc_range_us: RcRange = DEFAULT_RC_RANGE_US
                 ) -> tuple[np.ndarray, int]:
    """RC PWM → stick value of ``column`` (``u_roll`` … ``u_thrust``).

    Parameters
    ----------
    pwm : numpy.ndarray
        Pulse widths, µs (any numeric dtype; 0, 65535, NaN and negatives mean no value).
    column : str
        FlightTable stick column: ``u_thrust`` maps to 0…1, the others to −1…1.
    rc_range_us : tuple of float
        PWM min, centre, max, µs.

    Returns
    -------
    values : numpy.ndarray
        float64 sticks, clipped to their interval, NaN where there was no value.
    clipped : int
        Number of samples outside the RC range that were clipped.
    """
    return _to_unit(pwm, is_centred(column), rc_range_us)


def pwm_to_motor(pwm: np.ndarray, rc_range_us: RcRange = DEFAULT_RC_RANGE_US
                 ) -> tuple[np.ndarray, int]:
    """Servo/motor PWM, µs → motor output 0…1 (min → 0, max → 1); see :func:`pwm_to_stick`."""
    return _to_unit(pwm, False, rc_range_us)


def stick_to_pwm(value: np.ndarray, column: str, rc_range_us: RcRange = DEFAULT_RC_RANGE_US
                 ) -> np.ndarray:
    """Stick value of ``column`` → PWM, µs (float64, not rounded or clipped; NaN stays NaN)."""
    lo, centre, hi = rc_range_us
    v = np.asarray(value, dtype=np.float64)
    if is_centred(column):
        return centre + 0.5 * (hi - lo) * v
    return lo + (hi - lo) * v


def motor_to_pwm(value: np.ndarray, rc_range_us: RcRange = DEFAULT_RC_RANGE_US) -> np.ndarray:
    """Motor output 0…1 → PWM, µs (float64, not rounded or clipped; NaN stays NaN)."""
    lo, _, hi = rc_range_us
    return lo + (hi - lo) * np.asarray(value, dtype=np.float64)
