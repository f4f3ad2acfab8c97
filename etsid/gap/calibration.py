"""The calibration file of ``etsid gap`` (``calibration.json`` beside this module).

Every threshold of the likelihood criterion that is not physics or textbook statistics is
read from here; ``python benchmarks/gap_calibrate.py`` writes the file from recorded
no-effect pairs at a stated false-positive rate, and prints what it did. Nothing else
writes it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from etsid.errors import GapError
from etsid.files import read_json

CALIBRATION_PATH = Path(__file__).with_name("calibration.json")
CALIBRATION_SCHEMA = "etsid.gap.calibration/1"


@dataclass(frozen=True)
class Calibration:
    """Thresholds of the likelihood criterion.

    Attributes
    ----------
    mismatch_ratio : float
        A channel is mismatched when REAL's innovation variance under the nominal model is
        this many times its floor's (no-effect pairs stay below it at the stated rate).
    gain_per_sample : float
        Least held-out log-likelihood gain over the null, nats per scored sample, for an
        effect to be named (no-effect pairs stay below it at the stated rate).
    pair_gain_per_sample : float
        Least gain of a pair over its first effect, nats per scored sample, for the second
        effect to be named (single-effect pairs' best second effect stays below it).
    false_positive_rate : float
        The rate all were set at.
    source : dict
        What the script used (generators, pair counts, date), for the record.
    scale_tolerance : float
        Largest difference of REAL's gyro-vs-attitude slope from SIM's that no-effect pairs
        show (unitless; :mod:`etsid.gap.scale`); infinite in a file written before it
        existed (the scale is then not tested).
    """

    mismatch_ratio: float
    gain_per_sample: float
    pair_gain_per_sample: float
    false_positive_rate: float
    source: dict[str, Any]
    scale_tolerance: float = float("inf")


def from_dict(data: dict[str, Any], where: str) -> Calibration:
    """A :class:`Calibration` from the file's content; GapError naming ``where`` if not."""
    if data.get("schema") != CALIBRATION_SCHEMA:
        raise GapError(f"{where}: not an etsid gap calibration file (schema "
                       f"{data.get('schema')!r}, expected {CALIBRATION_SCHEMA!r})")
    try:
        th = data["thresholds"]
        return Calibration(float(th["mismatch_ratio"]), float(th["gain_per_sample"]),
                           float(th["pair_gain_per_sample"]),
                           float(data["false_positive_rate"]), dict(data.get("source", {})),
                           float(th.get("scale_tolerance", float("inf"))))
    except (KeyError, TypeError, ValueError) as err:
        raise GapError(f"{where}: calibration file lacks a threshold ({err})") from err


CALIBRATION_ENV = "ETSID_GAP_CALIBRATION"
"""Environment variable naming another calibration file (the benchmarks' rotations)."""


def load_calibration(path: str | None = None) -> Calibration:
    """The package's calibration (or the file at ``path``, or at $ETSID_GAP_CALIBRATION)."""
    return _load(path or os.environ.get(CALIBRATION_ENV) or str(CALIBRATION_PATH))


@lru_cache(maxsize=8)
def _load(path: str) -> Calibration:
    p = Path(path)
    try:
        data = read_json(p, "calibration", GapError, "gap calibration JSON")
    except GapError as err:
        raise GapError(f"{err}; run python benchmarks/gap_calibrate.py") from err
    return from_dict(data, str(p))


def calibration_dict(cal: Calibration) -> dict[str, Any]:
    """The file content of ``cal``."""
    return {"schema": CALIBRATION_SCHEMA,
            "false_positive_rate": cal.false_positive_rate,
            "thresholds": {"mismatch_ratio": cal.mismatch_ratio,
                           "gain_per_sample": cal.gain_per_sample,
                           "pair_gain_per_sample": cal.pair_gain_per_sample,
                           **({"scale_tolerance": cal.scale_tolerance}
                              if cal.scale_tolerance < float("inf") else {})},
            "source": cal.source}
