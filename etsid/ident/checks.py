"""Checks of the data before identification: the learning/validation split and warnings
about data too slow or too short to identify from."""

from __future__ import annotations

import pandas as pd

from etsid.errors import IdentError

MIN_TRAIN = 10
"""Fewest usable rows the learning part may have."""

MIN_RATE_HZ = 20.0
"""Below this sample rate a multirotor's body-rate dynamics (bandwidth of a few Hz) alias."""

SAMPLES_PER_PARAMETER = 10
"""Fewer usable samples than this many per consequent parameter of one rule: a warning."""


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
