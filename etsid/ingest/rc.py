"""Sticks and motor outputs from PWM for every reader: :mod:`etsid.pwm` plus the count.

Each reader that finds RC inputs or servo outputs in µs converts them here, with the RC
range of its :class:`~etsid.ingest.base.ReadOptions`, so every format clips the same way
and reports the clipped samples the same way (one :class:`~etsid.ingest.base.Issue` in
``repaired`` per source signal).
"""

from __future__ import annotations

import numpy as np

from etsid.ingest.base import Issue, ReadOptions
from etsid.pwm import pwm_to_motor, pwm_to_stick


def _note(clipped: int, source: str, options: ReadOptions, repaired: list[Issue]) -> None:
    if clipped:
        lo, _, hi = options.rc_range_us
        repaired.append(Issue(f"PWM outside the RC range {lo:g}–{hi:g} µs, clipped", clipped,
                              source))


def stick_from_pwm(pwm: np.ndarray, column: str, source: str, options: ReadOptions,
                   repaired: list[Issue]) -> np.ndarray:
    """RC PWM (µs) → ``column``'s stick value, clipped; clipped samples noted in ``repaired``.

    0, 65535 and non-finite PWM become NaN (see :func:`etsid.pwm.pwm_to_stick`).
    """
    values, clipped = pwm_to_stick(pwm, column, options.rc_range_us)
    _note(clipped, source, options, repaired)
    return values


def motor_from_pwm(pwm: np.ndarray, source: str, options: ReadOptions,
                   repaired: list[Issue]) -> np.ndarray:
    """Servo PWM (µs) → motor output 0…1, clipped; clipped samples noted in ``repaired``."""
    values, clipped = pwm_to_motor(pwm, options.rc_range_us)
    _note(clipped, source, options, repaired)
    return values
