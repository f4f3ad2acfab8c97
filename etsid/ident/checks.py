"""Checks of the data before identification: the learning/validation split and warnings
about data too slow or too short to identify from."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from etsid.errors import IdentError

MIN_TRAIN = 10
"""Fewest usable rows the learning part may have."""

MIN_RATE_HZ = 20.0
"""Below this sample rate a multirotor's body-rate dynamics (bandwidth of a few Hz) alias."""

COARSE_HZ = 10.0
"""Below this identification rate the rate model is refused: the body rates of a
multirotor change within one sample (2–10 Hz telemetry or default low-rate logging)."""

SAMPLES_PER_PARAMETER = 10
"""Fewer usable samples than this many per consequent parameter of one rule: a warning."""

MIN_VALIDATION_EXCITED = 2
"""Fewer excited validation samples than this many per consequent parameter of one rule
and output: the validation numbers carry little information (a warning)."""


def split_index(n: int, validate: float) -> int:
    """First validation row of ``n`` usable rows when the last ``validate`` of them are
    held out.

    Raises
    ------
    IdentError
        ``validate`` outside 0 … 0.9, or fewer than :data:`MIN_TRAIN` learning rows.
    """
    if not 0.0 <= validate <= 0.9:
        raise IdentError(f"--validate must be between 0 and 0.9, got {validate}")
    split = n - round(validate * n)
    if split < MIN_TRAIN:
        raise IdentError(f"only {n} usable rows: too few to learn on {split} of them "
                         "(lower --validate or use a longer log)")
    return split


def data_warnings(table: pd.DataFrame, n_samples: int, n_regressors: int,
                  rate_model: bool) -> list[str]:
    """Warnings about data too slow or too short to identify from (printed and in config).

    Parameters
    ----------
    n_samples
        Usable regression rows.
    n_regressors
        Regressors per output (a rule has ``n_regressors + 1`` parameters per output).
    rate_model
        True for the body-rate model (the sample-rate check applies to it only).
    """
    notes = []
    t = table.index.to_numpy()
    rate = (len(t) - 1) / (t[-1] - t[0]) if len(t) > 1 and t[-1] > t[0] else 0.0
    if rate_model and 0 < rate < MIN_RATE_HZ:
        notes.append(f"warning: body rates sampled at {rate:.3g} Hz; a multirotor's rate "
                     f"dynamics need ≥ {MIN_RATE_HZ:g} Hz (telemetry streams are often "
                     "slow: log at a higher rate), expect poor fits")
    needed = SAMPLES_PER_PARAMETER * (n_regressors + 1)
    if n_samples < needed:
        notes.append(f"warning: only {n_samples} usable samples for {n_regressors + 1} "
                     f"parameters per rule and output (want ≥ {needed}): the log is too "
                     "short for a reliable model; fewer lags (--output-lags/--input-lags) "
                     "or a longer flight help")
    return notes


def split_excited(excited: np.ndarray, validate: float) -> int:
    """First validation row when the validation part must hold the last ``validate`` of
    the *excited* usable rows (``excited``: one bool per usable row, in time order).

    The validation part starts at the excited row after which ``validate`` of the excited
    rows remain, so that it carries excitation even when the log ends with still hover or
    a landing. Without excited rows it is :func:`split_index`'s plain fraction.

    Raises
    ------
    IdentError
        As :func:`split_index`.
    """
    n = len(excited)
    plain = split_index(n, validate)
    idx = np.flatnonzero(excited)
    if validate == 0.0 or idx.size == 0:
        return plain
    first = idx[idx.size - max(1, round(validate * idx.size))]
    return max(int(first), MIN_TRAIN) if first < n else plain


def excitation_warnings(excited: np.ndarray, split: int, n_regressors: int, dt: float
                        ) -> list[str]:
    """One-line warnings when the learning or validation part is too still or too short
    for the model size (``n_regressors + 1`` parameters per rule and output)."""
    notes = []
    params = n_regressors + 1
    n_learn = int(np.count_nonzero(excited[:split]))
    n_val = int(np.count_nonzero(excited[split:]))
    if not excited.any():
        return ["warning: no excitation in the airborne data (every body rate's 1 s std "
                "below the threshold): the log is too still to identify the rate dynamics; "
                "the numbers describe sensor noise"]
    if n_learn < SAMPLES_PER_PARAMETER * params:
        notes.append(f"warning: only {n_learn * dt:.1f} s of excited data to learn "
                     f"{params} parameters per rule and output (want ≥ "
                     f"{SAMPLES_PER_PARAMETER * params * dt:.0f} s): too still or too short "
                     "for the model; fewer lags or more stick motion help")
    if len(excited) > split and n_val < MIN_VALIDATION_EXCITED * params:
        notes.append(f"warning: the validation part holds only {n_val * dt:.1f} s of "
                     f"excited data (want ≥ {MIN_VALIDATION_EXCITED * params * dt:.1f} s): "
                     "its numbers say little about the model")
    return notes


def motion_warnings(outputs: dict[str, Any], threshold: float) -> list[str]:
    """One line per output whose validation part barely moves (``informative`` false in
    :func:`etsid.ident.evaluate.output_metrics`): its metrics describe noise."""
    notes = []
    for y, entry in outputs.items():
        block = ((entry or {}).get("validation") or {}).get("one_step") or {}
        if block.get("informative") is False and not block.get("reason"):
            unit = entry.get("unit") or ""
            notes.append(f"warning: {y}: too little motion in the validation part (std "
                         f"{block['signal_std']:.3g} {unit} < {threshold:g}); its metrics "
                         "describe noise, its fit % is not informative")
    return notes


def refuse_coarse(rate_hz: float, source: str) -> None:
    """Refuse the rate model on a table slower than :data:`COARSE_HZ`.

    Raises
    ------
    IdentError
        One line naming the rate, the body-rate source and what would help.
    """
    if 0 < rate_hz < COARSE_HZ:
        raise IdentError(f"body rates at {rate_hz:.3g} Hz ({source}): too coarse for the "
                         f"rate loop (need ≥ {COARSE_HZ:g} Hz, better ≥ {MIN_RATE_HZ:g}); "
                         "log the gyro at a higher rate (PX4 high-rate logging profile, "
                         "ArduPilot IMU) or model other columns with --output/--regressors")
